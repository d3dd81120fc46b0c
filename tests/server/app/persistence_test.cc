// Snapshots, reload, retention, lazy loading, eviction and damaged stores through a real
// skimapd process and its real maps.sqlite (issue 10).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <fstream>
#include <set>
#include <thread>
#include <tuple>

#include "client/map_client.h"
#include "server/core/transfer/chunk_codec.h"
#include "skimap/free_columns_voxel.h"
#include "storage/sqlite.h"
#include "tests/common/skimapd_process.h"
#include "tests/common/synthetic_scene.h"
#include "tests/common/voxel_set.h"

namespace skimap::testing {
namespace {

using ::testing::HasSubstr;
// The occupancy grid covers the free-space volume of carving maps.
std::string Grid(client::MapClient& client, const std::string& map) {
  v1::GetOccupancyGridRequest request;
  request.set_map(map);
  // The volumes only: the views that clear seen-through obstacles are not persisted
  // (server/core/maps/grid_views.h).
  request.set_keep_seen_through(true);
  auto grid = client.GetOccupancyGrid(request);
  EXPECT_TRUE(grid.ok()) << grid.status();
  return grid.ok() ? grid->SerializeAsString() : "";
}

Eigen::Isometry3d ShiftedView(int i) {
  Eigen::Isometry3d pose = DefaultView();
  pose.translation().y() += 0.05 * i;
  return pose;
}

void CreateMap(client::MapClient& client, const std::string& id, bool carve) {
  v1::CreateMapRequest create;
  create.set_map_id(id);
  create.mutable_options()->set_resolution(0.04);
  create.mutable_options()->set_carve_free_space(carve);
  ASSERT_TRUE(client.CreateMap(create).ok());
}

void Stream(client::MapClient& client, const std::string& map, int first, int count) {
  std::unique_ptr<client::FrameStream> stream = client.OpenFrameStream({.window = 4});
  for (int i = first; i < first + count; ++i) {
    ASSERT_TRUE(stream->Send(MakeFrame(map, i, ShiftedView(i))).ok());
  }
  auto acks = stream->Finish();
  ASSERT_TRUE(acks.ok()) << acks.status();
  for (const v1::FrameAck& a : *acks) ASSERT_EQ(a.code(), 0) << a.message();
}

v1::UpdatePosesRequest MoveFrames(const std::string& map, std::vector<int> sequences) {
  v1::UpdatePosesRequest update;
  update.set_map(map);
  for (int i : sequences) {
    v1::PoseUpdate* u = update.add_updates();
    u->set_sequence(i);
    Eigen::Isometry3d moved = ShiftedView(i);
    moved.translation().x() += 0.09;
    SetPose(moved, u->mutable_pose());
  }
  return update;
}

// Waits until the background snapshot covers the whole journal.
v1::MapStats WaitForSnapshot(client::MapClient& client, const std::string& map) {
  v1::MapStats stats;
  for (int i = 0; i < 200; ++i) {
    stats = client.GetMap(map)->stats();
    if (stats.snapshot_position() == stats.journal_position()) break;
    absl::SleepFor(absl::Milliseconds(50));
  }
  return stats;
}

TEST(PersistenceTest, EveryVolumeSurvivesSnapshotPlusJournalTailAcrossKillNine) {
  SkimapdProcess server(SKIMAPD_PATH, {"--worker_threads=1", "--snapshot_interval_s=1"});
  ASSERT_TRUE(server.Start().ok());
  auto client = client::MapClient::Connect(server.address());
  CreateMap(*client, "carved", true);
  Stream(*client, "maps/carved", 0, 6);
  ASSERT_TRUE(client->UpdatePoses(MoveFrames("maps/carved", {1, 4})).ok());
  const v1::MapStats snapshotted = WaitForSnapshot(*client, "maps/carved");
  EXPECT_EQ(snapshotted.snapshot_position(), 7u);  // 6 frames and one pose update
  EXPECT_GT(snapshotted.snapshot_time().seconds(), 1700000000);
  // After the snapshot: more frames and a pose update of a frame from before it, so the
  // restart needs both the snapshot and the journal tail.
  std::unique_ptr<client::FrameStream> stream = client->OpenFrameStream({.window = 2});
  for (int i = 6; i < 9; ++i)
    ASSERT_TRUE(stream->Send(MakeFrame("maps/carved", i, ShiftedView(i))).ok());
  ASSERT_TRUE(stream->Finish().ok());
  ASSERT_TRUE(client->UpdatePoses(MoveFrames("maps/carved", {2, 7})).ok());
  const VoxelSet before = Voxels(*client, "maps/carved");
  const std::string grid_before = Grid(*client, "maps/carved");
  const v1::MapStats stats_before = client->GetMap("maps/carved")->stats();
  ASSERT_GT(before.size(), 500u);
  ASSERT_GT(stats_before.free_voxels(), 100u);

  ASSERT_TRUE(server.CrashAndRestart().ok());
  client = client::MapClient::Connect(server.address());
  EXPECT_EQ(Voxels(*client, "maps/carved"), before);
  EXPECT_EQ(Grid(*client, "maps/carved"), grid_before);
  const v1::MapStats after = client->GetMap("maps/carved")->stats();
  EXPECT_EQ(after.frames(), 9u);
  EXPECT_EQ(after.free_voxels(), stats_before.free_voxels());
  EXPECT_EQ(after.journal_position(), stats_before.journal_position());
  EXPECT_GE(after.snapshot_position(), 7u);
  // Sequences and poses came back from the frame index: a known sequence is refused, and
  // moving a frame again starts from its corrected pose (the map equals one built with the
  // final poses, checked through a second identical map below).
  EXPECT_EQ(client->IntegrateFrame(MakeFrame("maps/carved", 3, ShiftedView(3))).status().code(),
            absl::StatusCode::kAlreadyExists);
  ASSERT_TRUE(client->UpdatePoses(MoveFrames("maps/carved", {1, 2, 7})).ok());
  CreateMap(*client, "twin", true);
  Stream(*client, "maps/twin", 0, 9);
  ASSERT_TRUE(client->UpdatePoses(MoveFrames("maps/twin", {1, 2, 4, 7})).ok());
  EXPECT_EQ(Voxels(*client, "maps/carved"), Voxels(*client, "maps/twin"));
  EXPECT_EQ(Grid(*client, "maps/carved"), Grid(*client, "maps/twin"));
  // A clean stop writes a last snapshot: nothing is left to replay.
  EXPECT_EQ(server.Stop(), 0);
  ASSERT_TRUE(server.Start().ok());
  client = client::MapClient::Connect(server.address());
  const v1::MapStats clean = client->GetMap("maps/carved")->stats();
  EXPECT_EQ(clean.snapshot_position(), clean.journal_position());
}

TEST(PersistenceTest, PrunedFramesAnswerFailedPreconditionNamingThePolicy) {
  SkimapdProcess server(SKIMAPD_PATH,
                        {"--worker_threads=1", "--snapshot_interval_s=1", "--journal_retain_mb=0"});
  ASSERT_TRUE(server.Start().ok());
  auto client = client::MapClient::Connect(server.address());
  CreateMap(*client, "pruned", false);
  Stream(*client, "maps/pruned", 0, 4);
  v1::MapStats stats;
  // The byte count follows the pruned position on the map's queue: wait for both.
  for (int i = 0; i < 200 && (stats.pruned_position() < 4 || stats.journal_bytes() != 0); ++i) {
    absl::SleepFor(absl::Milliseconds(50));
    stats = client->GetMap("maps/pruned")->stats();
  }
  EXPECT_EQ(stats.pruned_position(), 4u);
  EXPECT_EQ(stats.journal_bytes(), 0u);
  auto refused = client->UpdatePoses(MoveFrames("maps/pruned", {0, 2}));
  EXPECT_EQ(refused.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(refused.status().message(), HasSubstr("updates[0].sequence: frame 0 is no longer in "
                                                    "the journal: pruned by the retention policy"));
  EXPECT_THAT(refused.status().message(), HasSubstr("--journal_retain_mb"));
  const VoxelSet before = Voxels(*client, "maps/pruned");
  // Still so after a restart, and the map (from its snapshot) is whole.
  ASSERT_TRUE(server.CrashAndRestart().ok());
  client = client::MapClient::Connect(server.address());
  EXPECT_EQ(Voxels(*client, "maps/pruned"), before);
  EXPECT_EQ(client->UpdatePoses(MoveFrames("maps/pruned", {3})).status().code(),
            absl::StatusCode::kFailedPrecondition);
  // New frames are journaled (and movable) until the next snapshot prunes them.
  Stream(*client, "maps/pruned", 4, 1);
}

TEST(PersistenceTest, EvictedMapsComeBackTransparentlyWhileQueriesGoOn) {
  // A budget far below one map: every map but the most recently used one is evicted.
  SkimapdProcess server(SKIMAPD_PATH, {"--worker_threads=1", "--snapshot_interval_s=1",
                                       "--memory_budget_mb=1", "--lazy_load"});
  ASSERT_TRUE(server.Start().ok());
  auto client = client::MapClient::Connect(server.address());
  const std::vector<std::string> maps = {"maps/a", "maps/b", "maps/c"};
  std::map<std::string, VoxelSet> expected;
  for (const std::string& m : maps) {
    CreateMap(*client, m.substr(5), true);
    Stream(*client, m, 0, 5);
    expected[m] = Voxels(*client, m);
    ASSERT_GT(expected[m].size(), 500u);
  }
  // Round-robin queries: each one may load its map while another is evicted.
  int unloaded_seen = 0;
  for (int round = 0; round < 6; ++round) {
    for (const std::string& m : maps) {
      EXPECT_EQ(Voxels(*client, m), expected[m]) << m << " round " << round;
      absl::SleepFor(absl::Milliseconds(400));
    }
    auto listed = client->ListMaps(v1::ListMapsRequest());
    ASSERT_TRUE(listed.ok());
    for (const v1::Map& m : listed->maps()) unloaded_seen += m.stats().loaded() ? 0 : 1;
  }
  EXPECT_GT(unloaded_seen, 0) << "the memory budget never evicted a map";
  // Writes reach an evicted map too; one that arrives while the map leaves memory gets
  // Unavailable (nothing journaled) and succeeds when retried.
  for (int i = 5; i < 7; ++i) {
    absl::StatusOr<v1::FrameAck> ack;
    for (int attempt = 0; attempt < 20; ++attempt) {
      ack = client->IntegrateFrame(MakeFrame("maps/a", i, ShiftedView(i)));
      if (ack.status().code() != absl::StatusCode::kUnavailable) break;
    }
    ASSERT_TRUE(ack.ok()) << ack.status();
  }
  EXPECT_EQ(client->GetMap("maps/a")->stats().frames(), 7u);
  // Lazy loading at start: maps stay on disk until used.
  ASSERT_TRUE(server.CrashAndRestart().ok());
  client = client::MapClient::Connect(server.address());
  auto listed = client->ListMaps(v1::ListMapsRequest());
  ASSERT_TRUE(listed.ok());
  ASSERT_EQ(listed->maps_size(), 3);
  for (const v1::Map& m : listed->maps()) EXPECT_FALSE(m.stats().loaded()) << m.name();
  EXPECT_EQ(Voxels(*client, "maps/b"), expected["maps/b"]);
  EXPECT_TRUE(client->GetMap("maps/b")->stats().loaded());
}

// Damages the stored chunks of one map with `sql` (run on maps.sqlite while skimapd is
// stopped).
void Damage(const std::string& data_dir, const std::string& sql) {
  auto db = storage::Database::Open(data_dir + "/maps.sqlite");
  ASSERT_TRUE(db.ok()) << db.status();
  ASSERT_TRUE((*db)->Exec(sql).ok());
}

TEST(PersistenceTest, ACorruptMapAnswersDataLossNamingItAndTheOthersServe) {
  SkimapdProcess server(SKIMAPD_PATH, {"--worker_threads=1"});
  ASSERT_TRUE(server.Start().ok());
  auto client = client::MapClient::Connect(server.address());
  for (const char* id : {"good", "flipped", "cut", "newer"}) {
    CreateMap(*client, id, false);
    Stream(*client, absl::StrCat("maps/", id), 0, 3);
  }
  const VoxelSet good = Voxels(*client, "maps/good");
  ASSERT_EQ(server.Stop(), 0);  // a clean stop snapshots every map
  // Four changed bytes in a chunk, a truncated chunk, a chunk of a newer format version.
  Damage(server.data_dir(),
         "UPDATE chunks SET bytes = substr(bytes, 1, 40) || x'A5C3A5C3' || substr(bytes, 45) "
         "WHERE map = 'flipped' AND volume = 'rgb' AND rowid = (SELECT min(rowid) FROM chunks "
         "WHERE map = 'flipped' AND volume = 'rgb')");
  Damage(server.data_dir(),
         "UPDATE chunks SET bytes = substr(bytes, 1, length(bytes) / 2) WHERE map = 'cut' AND "
         "volume = 'rgb'");
  Damage(server.data_dir(),
         "UPDATE chunks SET bytes = substr(bytes, 1, 4) || x'09' || substr(bytes, 6) WHERE "
         "map = 'newer' AND volume = 'rgb'");
  ASSERT_TRUE(server.Start().ok());
  client = client::MapClient::Connect(server.address());
  EXPECT_EQ(Voxels(*client, "maps/good"), good);
  for (const char* id : {"flipped", "cut"}) {
    auto map = client->GetMap(absl::StrCat("maps/", id));
    EXPECT_EQ(map.status().code(), absl::StatusCode::kDataLoss) << id;
    EXPECT_THAT(map.status().message(), HasSubstr(absl::StrCat("map maps/", id)));
    EXPECT_THAT(map.status().message(), HasSubstr("chunk rgb"));
  }
  auto newer = client->GetMap("maps/newer");
  EXPECT_EQ(newer.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(newer.status().message(), HasSubstr("format version 9 is newer"));
  // The server stays up and the other maps take writes; a damaged map can be deleted.
  Stream(*client, "maps/good", 3, 1);
  EXPECT_TRUE(client->DeleteMap("maps/cut").ok());
  EXPECT_TRUE(server.Running());
}

// Until 2026-12-02 the free volume held one WeightVoxel per column; a store written then
// loads, its columns folded into blocks: the same grid and the same free columns.
TEST(PersistenceTest, AFreeVolumeStoredPerColumnLoadsAsBlocks) {
  SkimapdProcess server(SKIMAPD_PATH, {"--worker_threads=1"});
  ASSERT_TRUE(server.Start().ok());
  auto client = client::MapClient::Connect(server.address());
  CreateMap(*client, "carved", true);
  Stream(*client, "maps/carved", 0, 6);
  const std::string grid_before = Grid(*client, "maps/carved");
  const uint64_t free_before = client->GetMap("maps/carved")->stats().free_voxels();
  ASSERT_GT(free_before, 100u);
  ASSERT_EQ(server.Stop(), 0);  // a clean stop snapshots every map
  // Rewrites every stored free chunk as the old per-column chunk of the same columns.
  {
    auto db = storage::Database::Open(server.data_dir() + "/maps.sqlite");
    ASSERT_TRUE(db.ok()) << db.status();
    auto read = (*db)->Prepare(
        "SELECT cx, cy, cz, bytes FROM chunks WHERE map = 'carved' AND volume = 'free'");
    ASSERT_TRUE(read.ok()) << read.status();
    std::vector<std::tuple<server::ChunkCoord, std::string>> old_chunks;
    uint64_t columns = 0;
    while (*read->Step()) {
      const server::ChunkCoord c{int32_t(read->ColumnInt(0)), int32_t(read->ColumnInt(1)),
                                 int32_t(read->ColumnInt(2))};
      VoxelBatch<FreeColumnsVoxel> blocks;
      ASSERT_TRUE(server::DecodeVoxelChunk(c, read->ColumnBlob(3), &blocks).ok());
      std::vector<VoxelBatch<WeightVoxel>::Item> per_column;
      for (const auto& b : blocks.items()) {
        for (int32_t dx = 0; dx < FreeColumnsVoxel::kSide; ++dx) {
          for (int32_t dy = 0; dy < FreeColumnsVoxel::kSide; ++dy) {
            const uint32_t n =
                b.data.counts[size_t(FreeColumnsVoxel::Index(b.key.x + dx, b.key.y + dy))];
            if (n > 0) per_column.push_back({{b.key.x + dx, b.key.y + dy, 0}, {float(n)}});
          }
        }
      }
      std::sort(per_column.begin(), per_column.end(),
                [](const auto& a, const auto& b) { return a.key < b.key; });
      columns += per_column.size();
      old_chunks.emplace_back(c, server::EncodeVoxelChunk<WeightVoxel>(c, per_column));
    }
    ASSERT_EQ(columns, free_before);
    for (const auto& [c, bytes] : old_chunks) {
      auto write = (*db)->Prepare(
          "UPDATE chunks SET bytes = ? WHERE map = 'carved' AND volume = 'free' AND cx = ? AND "
          "cy = ? AND cz = ?");
      ASSERT_TRUE(write.ok()) << write.status();
      ASSERT_TRUE(write->BindBlob(1, bytes).ok());
      ASSERT_TRUE(write->BindInt(2, c.x).ok());
      ASSERT_TRUE(write->BindInt(3, c.y).ok());
      ASSERT_TRUE(write->BindInt(4, c.z).ok());
      ASSERT_TRUE(write->Step().ok());
    }
  }
  ASSERT_TRUE(server.Start().ok());
  client = client::MapClient::Connect(server.address());
  EXPECT_EQ(client->GetMap("maps/carved")->stats().free_voxels(), free_before);
  EXPECT_EQ(Grid(*client, "maps/carved"), grid_before);
  // It goes on taking frames, and a stop writes its chunks as blocks again.
  Stream(*client, "maps/carved", 6, 2);
  EXPECT_GE(client->GetMap("maps/carved")->stats().free_voxels(), free_before);
}

TEST(PersistenceTest, AStoreFromANewerServerOrNotSqliteIsRefusedAtStart) {
  SkimapdProcess server(SKIMAPD_PATH, {"--worker_threads=1"});
  ASSERT_TRUE(server.Start().ok());
  ASSERT_EQ(server.Stop(), 0);
  Damage(server.data_dir(), "INSERT INTO schema_version (version, name) VALUES (99, 'future')");
  EXPECT_FALSE(server.Start().ok());
  EXPECT_FALSE(server.Running());
  // Not a database at all.
  std::ofstream(server.data_dir() + "/maps.sqlite", std::ios::trunc)
      << "not sqlite, 32 bytes long!!";
  EXPECT_FALSE(server.Start().ok());
  EXPECT_FALSE(server.Running());
}

}  // namespace
}  // namespace skimap::testing
