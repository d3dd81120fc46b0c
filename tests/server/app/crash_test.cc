// Crash consistency of a real skimapd process: SIGKILL at random moments while frames
// stream in.
//
// Two client threads stream frames (sequences 0, 1, 2, ..., each from a different view, so
// every frame changes the map) into their own map, one carving free space and one not, over
// a FrameStream with a window of 4. A third thread kills the server with SIGKILL at a
// random moment within the time the streams need and restarts it on the same data dir.
// Each client records the acks it received. After the restart, for each map:
//   (a) every frame whose OK ack arrived is in the map: a stream journals in order, so the
//       map holds exactly frames 0..k-1 with k = stats.frames >= highest acked + 1 (and
//       k <= frames sent; journal_position == k);
//   (b) the map equals a map rebuilt in the restarted server (a fresh id, same options)
//       from frames 0..k-1: every voxel (centre, weight, rgb; min_voxel_weight 0), the
//       free-space column count and the occupancy grid, exactly;
//   (c) PRAGMA integrity_check of DATA_DIR/maps.sqlite answers "ok";
//   (d) the server serves: the rebuild's frames are acknowledged OK.
// Then the clients resume like a real client: they re-send from their highest acked
// sequence + 1 (at least frame k-1), expect ALREADY_EXISTS for what the map already holds
// and OK from k on; the next kill follows.
//
// Environment (for scripts/crash_soak.sh): SKIMAP_CRASH_ROUNDS (kills, default 5),
// SKIMAP_CRASH_SEED (default random; printed, with the kill delays, for a rerun),
// SKIMAP_CRASH_FRAMES (frames per stream and round, default 24).
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <mutex>
#include <random>
#include <set>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "client/map_client.h"
#include "tests/common/skimapd_process.h"
#include "tests/common/synthetic_scene.h"
#include "tests/common/voxel_set.h"

namespace skimap::testing {
namespace {

constexpr int kWindow = 4;
constexpr int kAlreadyExists = static_cast<int>(absl::StatusCode::kAlreadyExists);

uint64_t EnvNumber(const char* name, uint64_t fallback) {
  const char* value = std::getenv(name);
  if (value == nullptr || *value == '\0') return fallback;
  return std::strtoull(value, nullptr, 10);
}

v1::Frame Frame(const std::string& map, uint64_t sequence) {
  return MakeFrame(map, sequence, OrbitView(sequence));
}

v1::OccupancyGrid Grid(client::MapClient& client, const std::string& map) {
  v1::GetOccupancyGridRequest request;
  request.set_map(map);
  request.mutable_region()->set_min_x(-3.0);
  request.mutable_region()->set_min_y(-3.5);
  request.mutable_region()->set_max_x(4.0);
  request.mutable_region()->set_max_y(3.5);
  // The volumes only: the views that clear seen-through obstacles are not persisted
  // (server/core/maps/grid_views.h).
  request.set_keep_seen_through(true);
  auto grid = client.GetOccupancyGrid(request);
  EXPECT_TRUE(grid.ok()) << map << ": " << grid.status();
  return grid.value_or(v1::OccupancyGrid());
}

// PRAGMA integrity_check of the SQLite file at `path`, opened read-only: "ok" or the
// problems it lists (or why it could not run).
std::string IntegrityCheck(const std::string& path) {
  sqlite3* db = nullptr;
  if (sqlite3_open_v2(path.c_str(), &db, SQLITE_OPEN_READONLY, nullptr) != SQLITE_OK) {
    std::string why = db != nullptr ? sqlite3_errmsg(db) : "out of memory";
    sqlite3_close(db);
    return "open: " + why;
  }
  sqlite3_busy_timeout(db, 10000);
  sqlite3_stmt* st = nullptr;
  std::vector<std::string> rows;
  if (sqlite3_prepare_v2(db, "PRAGMA integrity_check", -1, &st, nullptr) != SQLITE_OK) {
    rows.push_back(absl::StrCat("prepare: ", sqlite3_errmsg(db)));
  } else {
    int rc;
    while ((rc = sqlite3_step(st)) == SQLITE_ROW) {
      rows.emplace_back(reinterpret_cast<const char*>(sqlite3_column_text(st, 0)));
    }
    if (rc != SQLITE_DONE) rows.push_back(absl::StrCat("step: ", sqlite3_errmsg(db)));
  }
  sqlite3_finalize(st);
  sqlite3_close(db);
  return absl::StrJoin(rows, "\n");
}

// One map under test, across rounds.
struct CrashMap {
  std::string id;
  bool carve = false;
  uint64_t frames = 0;         // k: frames 0..k-1 are in the map (verified after each round)
  int64_t highest_acked = -1;  // highest sequence whose OK ack the client received
  std::string name() const { return "maps/" + id; }
};

v1::CreateMapRequest CreateRequest(const std::string& id, bool carve) {
  v1::CreateMapRequest request;
  request.set_map_id(id);
  request.mutable_options()->set_resolution(0.04);
  request.mutable_options()->set_carve_free_space(carve);
  return request;
}

// What one client saw in one round.
struct StreamLog {
  std::mutex mu;
  std::vector<v1::FrameAck> acks;  // in arrival order (guarded by mu)
  uint64_t attempted_end = 0;      // one past the last sequence handed to Send
  absl::Status send, finish;
};

// Streams sequences [from, end) of `map` (stopping early when the stream breaks or at
// `stop`), recording every ack as it arrives.
void StreamFrames(client::MapClient& client, const std::string& map, uint64_t from, uint64_t end,
                  absl::Time stop, StreamLog* log) {
  log->attempted_end = from;
  std::unique_ptr<client::FrameStream> stream =
      client.OpenFrameStream({.window = kWindow, .on_ack = [log](const v1::FrameAck& ack) {
                                std::lock_guard<std::mutex> lock(log->mu);
                                log->acks.push_back(ack);
                              }});
  for (uint64_t s = from; s < end && absl::Now() < stop; ++s) {
    const v1::Frame frame = Frame(map, s);
    log->attempted_end = s + 1;
    log->send = stream->Send(frame);
    if (!log->send.ok()) break;
  }
  log->finish = stream->Finish().status();
}

// Sends frames 0..k-1 of `source`'s views into a fresh map with the same options, in order,
// in the running server; every frame must be acknowledged OK.
void Rebuild(client::MapClient& client, const CrashMap& source, const std::string& id) {
  auto created = client.CreateMap(CreateRequest(id, source.carve));
  ASSERT_TRUE(created.ok()) << created.status();
  std::unique_ptr<client::FrameStream> stream = client.OpenFrameStream({.window = kWindow});
  for (uint64_t s = 0; s < source.frames; ++s) {
    ASSERT_TRUE(stream->Send(Frame("maps/" + id, s)).ok()) << "rebuild frame " << s;
  }
  auto acks = stream->Finish();
  ASSERT_TRUE(acks.ok()) << acks.status();
  ASSERT_EQ(acks->size(), source.frames);
  for (const v1::FrameAck& ack : *acks) {
    ASSERT_EQ(ack.code(), 0) << "rebuild frame " << ack.sequence() << ": " << ack.message();
  }
}

TEST(CrashTest, AcknowledgedFramesSurviveSigkillAtRandomMoments) {
  const uint64_t rounds = EnvNumber("SKIMAP_CRASH_ROUNDS", 5);
  const uint64_t frames_per_round = std::max<uint64_t>(1, EnvNumber("SKIMAP_CRASH_FRAMES", 24));
  const uint64_t seed = EnvNumber("SKIMAP_CRASH_SEED", std::random_device()());
  std::printf(
      "crash_test: SKIMAP_CRASH_SEED=%llu SKIMAP_CRASH_ROUNDS=%llu "
      "SKIMAP_CRASH_FRAMES=%llu\n",
      static_cast<unsigned long long>(seed), static_cast<unsigned long long>(rounds),
      static_cast<unsigned long long>(frames_per_round));
  std::fflush(stdout);
  std::mt19937_64 rng(seed);

  SkimapdProcess server(SKIMAPD_PATH, {});
  ASSERT_TRUE(server.Start().ok());
  const std::string db_path = server.data_dir() + "/maps.sqlite";
  std::vector<CrashMap> maps = {{.id = "plain", .carve = false}, {.id = "carved", .carve = true}};
  {
    auto client = client::MapClient::Connect(server.address());
    for (const CrashMap& m : maps)
      ASSERT_TRUE(client->CreateMap(CreateRequest(m.id, m.carve)).ok());
  }

  // Round 0, no kill: the first frames of both maps, timed, to learn how long a round's
  // streams need (the window for the kill moments).
  absl::Duration stream_time;
  {
    auto client = client::MapClient::Connect(server.address());
    StreamLog logs[2];
    const absl::Time start = absl::Now();
    std::vector<std::thread> clients;
    for (int i = 0; i < 2; ++i) {
      clients.emplace_back([&, i] {
        StreamFrames(*client, maps[i].name(), 0, frames_per_round, absl::InfiniteFuture(),
                     &logs[i]);
      });
    }
    for (std::thread& t : clients) t.join();
    stream_time = std::max(absl::Now() - start, absl::Milliseconds(20));
    for (int i = 0; i < 2; ++i) {
      ASSERT_TRUE(logs[i].finish.ok()) << logs[i].finish;
      ASSERT_EQ(logs[i].acks.size(), frames_per_round);
      for (const v1::FrameAck& ack : logs[i].acks) ASSERT_EQ(ack.code(), 0) << ack.message();
      maps[i].frames = frames_per_round;
      maps[i].highest_acked = int64_t(frames_per_round) - 1;
    }
  }
  std::printf("crash_test: %llu frames per map stream in %s\n",
              static_cast<unsigned long long>(frames_per_round),
              absl::FormatDuration(stream_time).c_str());

  // A round may take its streams (cut off at 3x the measured time + 5 s), a restart with
  // replay, and the rebuilds; anything near this bound means something hangs.
  const absl::Duration round_limit = 3 * stream_time + absl::Seconds(60);
  std::uniform_int_distribution<int64_t> delay_us(0, absl::ToInt64Microseconds(stream_time));
  const absl::Time test_start = absl::Now();
  for (uint64_t round = 1; round <= rounds; ++round) {
    const absl::Time round_start = absl::Now();
    const absl::Duration delay = absl::Microseconds(delay_us(rng));
    auto client = client::MapClient::Connect(server.address());
    StreamLog logs[2];
    uint64_t resend_from[2], first[2];
    for (int i = 0; i < 2; ++i) {
      // Re-send what the client cannot know is in the map (and at least the last frame).
      first[i] = maps[i].frames;
      resend_from[i] =
          std::min<uint64_t>(maps[i].highest_acked + 1, first[i] == 0 ? 0 : first[i] - 1);
    }
    const absl::Time stop = absl::Now() + 3 * stream_time + absl::Seconds(5);
    std::vector<std::thread> threads;
    for (int i = 0; i < 2; ++i) {
      threads.emplace_back([&, i] {
        StreamFrames(*client, maps[i].name(), resend_from[i], first[i] + frames_per_round, stop,
                     &logs[i]);
      });
    }
    absl::Status restarted;
    threads.emplace_back([&] {
      absl::SleepFor(delay);
      restarted = server.CrashAndRestart();
    });
    for (std::thread& t : threads) t.join();
    ASSERT_TRUE(restarted.ok()) << "round " << round << ": " << restarted;
    client = client::MapClient::Connect(server.address());

    // (c) The file is sound right after the crash (and before anything else writes).
    EXPECT_EQ(IntegrityCheck(db_path), "ok") << "round " << round;

    std::string summary;
    for (int i = 0; i < 2; ++i) {
      CrashMap& m = maps[i];
      SCOPED_TRACE(absl::StrCat("round ", round, ", ", m.name(), ", seed ", seed));
      const StreamLog& log = logs[i];
      int64_t highest = m.highest_acked;
      uint64_t expected_next = resend_from[i];
      for (const v1::FrameAck& ack : log.acks) {
        // Acks of one stream arrive in sequence order (one worker per map, in order).
        EXPECT_EQ(ack.sequence(), expected_next) << "acks out of order";
        expected_next = ack.sequence() + 1;
        if (ack.sequence() < first[i]) {
          EXPECT_EQ(ack.code(), kAlreadyExists) << "re-sent frame " << ack.sequence() << " of "
                                                << first[i] << " in the map: " << ack.message();
        } else {
          EXPECT_EQ(ack.code(), 0) << "frame " << ack.sequence() << ": " << ack.message();
          if (ack.code() == 0) highest = std::max<int64_t>(highest, ack.sequence());
        }
      }
      auto info = client->GetMap(m.name());
      ASSERT_TRUE(info.ok()) << info.status();
      const uint64_t k = info->stats().frames();
      // (a) Every acknowledged frame survived; nothing unsent or lost in between.
      EXPECT_GE(int64_t(k), highest + 1) << "an acknowledged frame is missing after the crash";
      EXPECT_GE(k, m.frames) << "frames of an earlier round are gone";
      EXPECT_LE(k, std::max(log.attempted_end, m.frames)) << "more frames than were sent";
      EXPECT_EQ(info->stats().journal_position(), k);
      m.frames = k;
      m.highest_acked = highest;
      absl::StrAppend(&summary, " ", m.id, ": acked<", highest + 1, " k=", k, " sent<",
                      log.attempted_end, " (", log.acks.size(), " acks, stream ",
                      log.finish.ok() ? "done" : "broken", ");");

      // (b) Equal, voxel by voxel, to the same prefix rebuilt in the restarted server;
      // (d) which also shows the restarted server integrating new frames.
      const std::string rebuilt_id = absl::StrCat(m.id, "-rebuilt-", round);
      ASSERT_NO_FATAL_FAILURE(Rebuild(*client, m, rebuilt_id));
      const std::string rebuilt = "maps/" + rebuilt_id;
      auto rebuilt_info = client->GetMap(rebuilt);
      ASSERT_TRUE(rebuilt_info.ok()) << rebuilt_info.status();
      EXPECT_EQ(rebuilt_info->stats().frames(), k);
      EXPECT_EQ(rebuilt_info->stats().voxels(), info->stats().voxels());
      EXPECT_EQ(rebuilt_info->stats().free_voxels(), info->stats().free_voxels());
      if (m.carve && k > 0) {
        EXPECT_GT(info->stats().free_voxels(), 0u);
      }
      const VoxelSet recovered = Voxels(*client, m.name());
      EXPECT_EQ(recovered.size(), info->stats().voxels());
      EXPECT_TRUE(recovered == Voxels(*client, rebuilt))
          << "the recovered map differs from frames 0.." << k << " rebuilt";
      const v1::OccupancyGrid grid = Grid(*client, m.name()), rebuilt_grid = Grid(*client, rebuilt);
      EXPECT_EQ(grid.frames(), k);
      EXPECT_EQ(grid.width(), rebuilt_grid.width());
      EXPECT_EQ(grid.height(), rebuilt_grid.height());
      EXPECT_TRUE(grid.data() == rebuilt_grid.data()) << "occupancy grids differ";
      EXPECT_TRUE(client->DeleteMap(rebuilt).ok());
    }
    const absl::Duration round_time = absl::Now() - round_start;
    std::printf("crash_test: round %llu: kill after %s;%s %s\n",
                static_cast<unsigned long long>(round), absl::FormatDuration(delay).c_str(),
                summary.c_str(), absl::FormatDuration(round_time).c_str());
    std::fflush(stdout);
    EXPECT_LT(round_time, round_limit) << "round " << round << " too slow";
    if (HasFailure()) {
      std::printf("crash_test: failed in round %llu; rerun with SKIMAP_CRASH_SEED=%llu\n",
                  static_cast<unsigned long long>(round), static_cast<unsigned long long>(seed));
      return;
    }
  }
  std::printf("crash_test: %llu kills in %s; maps hold %llu and %llu frames\n",
              static_cast<unsigned long long>(rounds),
              absl::FormatDuration(absl::Now() - test_start).c_str(),
              static_cast<unsigned long long>(maps[0].frames),
              static_cast<unsigned long long>(maps[1].frames));
  // A clean stop leaves a sound file as well.
  EXPECT_EQ(server.Stop(), 0);
  EXPECT_EQ(IntegrityCheck(db_path), "ok");
}

}  // namespace
}  // namespace skimap::testing
