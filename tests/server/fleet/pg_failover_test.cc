// A fleet of real skimapd processes on a replicated PostgreSQL (Debian's pg_auto_failover,
// started by tests/common/pg_cluster.h): the database primary killed with -9 ten times
// while two nodes ingest from two clients each, a primary paused past the failover
// timeout and resumed, and a node that must replicate refusing a lone server. After each,
// every acknowledged frame is in its map exactly once (voxel by voxel against a rebuild,
// rebuild_check.h) and the database passes amcheck and a journal consistency query.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <fstream>
#include <mutex>
#include <random>
#include <thread>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_split.h"
#include "client/map_client.h"
#include "tests/common/fleet_streamer.h"
#include "tests/common/pg_cluster.h"
#include "tests/common/postgres_server.h"
#include "tests/common/rebuild_check.h"
#include "tests/common/skimapd_process.h"
#include "tests/common/synthetic_scene.h"
// After Eigen (synthetic_scene.h): httplib's <resolv.h> defines `_res`, an Eigen name.
#include <httplib.h>  // NOLINT(build/include_order)

namespace skimap::testing {
namespace {

// Leases shorter than a failover (about 5 s with pg_cluster.sh's monitor settings): maps
// may change hands while the database is away, so fencing across a failover is exercised.
constexpr int kLeaseTtlMs = 3000;
constexpr int kNodes = 2;    // skimapd nodes
constexpr int kClients = 4;  // two per node, a map each

class PgFailoverTest : public ::testing::Test {
 protected:
  void StartCluster(int data_nodes) {
    cluster_ = std::make_unique<PgCluster>(data_nodes);
    absl::Status up = cluster_->Start();
    ASSERT_TRUE(up.ok()) << up;
  }
  void StartNodes() {
    for (int i = 0; i < kNodes; ++i) {
      nodes_.push_back(std::make_unique<SkimapdProcess>(
          SKIMAPD_PATH, std::vector<std::string>{"--store=" + cluster_->uri(),
                                                 absl::StrCat("--lease_ttl_ms=", kLeaseTtlMs),
                                                 "--snapshot_interval_s=1", "--worker_threads=1",
                                                 "--store_failover_timeout_ms=60000"}));
      ASSERT_TRUE(nodes_.back()->Start().ok()) << "node " << i;
      addresses_.push_back(nodes_.back()->address());
    }
    for (int i = 0; i < kClients; ++i) {
      auto c = client::MapClient::Connect(addresses_[i % kNodes]);
      auto created = c->CreateMap(FleetMapRequest(absl::StrCat("m", i)));
      ASSERT_TRUE(created.ok()) << created.status();
    }
  }
  // Streams frames [0, frames) into map i from client i, `pace` between frames while
  // `paced` holds; the time each frame was sent and acknowledged goes to on_ack.
  void StartClients(uint64_t frames, absl::Duration pace,
                    std::function<void(absl::Time sent, absl::Time acked)> on_ack) {
    for (int i = 0; i < kClients; ++i) {
      const std::string map = absl::StrCat("maps/m", i);
      streamers_.push_back(
          std::make_unique<FleetStreamer>(addresses_, map, [this, map, pace](uint64_t s) {
            if (paced_) absl::SleepFor(pace);
            return MakeFrame(map, s, OrbitView(s));
          }));
      streamers_.back()->StartAt(i % kNodes);
      streamers_.back()->OnAck([on_ack](uint64_t, absl::Duration latency) {
        const absl::Time now = absl::Now();
        on_ack(now - latency, now);
      });
    }
    results_.resize(kClients);
    const absl::Time deadline = absl::Now() + absl::Minutes(15);
    for (int i = 0; i < kClients; ++i) {
      clients_.emplace_back(
          [this, i, frames, deadline] { results_[i] = streamers_[i]->Run(0, frames, deadline); });
    }
  }
  // Stops the streams (FleetStreamer::Stop): each ends once the frames it sent are
  // confirmed.
  void StopClients() {
    for (const auto& s : streamers_) s->Stop();
  }
  void JoinClients() {
    paced_ = false;
    for (std::thread& t : clients_) t.join();
    clients_.clear();
    for (int i = 0; i < kClients; ++i)
      ASSERT_TRUE(results_[i].ok()) << "map " << i << ": " << results_[i];
  }
  // Every map holds each of its frames (the first `frames`, or what its client confirmed
  // when 0) once, equal to a rebuild; the primary's indexes pass amcheck and every map's
  // journal is gap-free up to its last position.
  void ExpectEveryFrameOnceAndAConsistentDatabase(uint64_t frames = 0) {
    auto client = client::MapClient::Connect(addresses_[0], {.timeout = absl::Seconds(60)});
    for (int i = 0; i < kClients; ++i) {
      SCOPED_TRACE(absl::StrCat("maps/m", i));
      std::vector<uint64_t> all(frames > 0 ? frames : streamers_[i]->confirmed());
      for (uint64_t s = 0; s < all.size(); ++s) all[s] = s;
      ASSERT_NO_FATAL_FAILURE(ExpectEqualToRebuild(*client, absl::StrCat("maps/m", i), all,
                                                   absl::StrCat("m", i, "-re")));
    }
    absl::StatusOr<int> primary = cluster_->Primary();
    ASSERT_TRUE(primary.ok()) << primary.status();
    absl::StatusOr<std::string> checked = cluster_->Psql(
        *primary,
        "CREATE EXTENSION IF NOT EXISTS amcheck; SELECT count(bt_index_check(c.oid, true)) FROM "
        "pg_index i JOIN pg_class c ON c.oid = i.indexrelid JOIN pg_am a ON a.oid = c.relam "
        "WHERE c.relnamespace = 'public'::regnamespace AND a.amname = 'btree'");
    ASSERT_TRUE(checked.ok()) << checked.status();
    EXPECT_GT(std::stoi(std::string(absl::StripAsciiWhitespace(*checked))), 0);
    // Positions are numbered under the map's row lock and a failed append rolls its
    // numbers back: the journal after the pruned prefix is contiguous and ends at
    // last_position.
    absl::StatusOr<std::string> gaps = cluster_->Psql(
        *primary,
        "SELECT m.id FROM maps m JOIN journal j ON j.map = m.id GROUP BY m.id, m.last_position "
        "HAVING max(j.position) <> m.last_position OR count(*) <> max(j.position) - "
        "min(j.position) + 1");
    ASSERT_TRUE(gaps.ok()) << gaps.status();
    EXPECT_EQ(absl::StripAsciiWhitespace(*gaps), "") << "maps with journal gaps";
  }
  // A node's skimap_store_* samples ("name{labels} value" lines).
  std::string StoreMetrics(int node) {
    httplib::Client http("127.0.0.1", nodes_[node]->http_port());
    httplib::Result r = http.Get("/metrics");
    std::string out;
    if (!r) return out;
    for (absl::string_view line : absl::StrSplit(r->body, '\n')) {
      if (absl::StartsWith(line, "skimap_store_")) absl::StrAppend(&out, line, "\n");
    }
    return out;
  }

  std::unique_ptr<PgCluster> cluster_;
  std::vector<std::unique_ptr<SkimapdProcess>> nodes_;
  std::vector<std::string> addresses_;
  std::vector<std::unique_ptr<FleetStreamer>> streamers_;
  std::vector<std::thread> clients_;
  std::vector<absl::Status> results_;
  std::atomic<bool> paced_{true};
};

// Per kill: the time from the kill to the first acknowledgement of a frame sent after it.
struct FirstAcks {
  std::mutex mu;
  std::vector<absl::Time> killed, first_ack;
  void Ack(absl::Time sent, absl::Time acked) {
    std::lock_guard<std::mutex> lock(mu);
    if (!killed.empty() && first_ack.size() < killed.size() && sent > killed.back()) {
      first_ack.push_back(acked);
    }
  }
  void Kill(absl::Time at) {
    std::lock_guard<std::mutex> lock(mu);
    killed.push_back(at);
  }
  // True once the last kill's first new ack is in (waits up to `timeout`).
  bool WaitForAck(absl::Duration timeout) {
    const absl::Time deadline = absl::Now() + timeout;
    for (;;) {
      {
        std::lock_guard<std::mutex> lock(mu);
        if (first_ack.size() == killed.size()) return true;
      }
      if (absl::Now() > deadline) return false;
      absl::SleepFor(absl::Milliseconds(50));
    }
  }
  // Seconds from each kill to its first new ack.
  std::vector<double> Seconds() {
    std::lock_guard<std::mutex> lock(mu);
    std::vector<double> out;
    for (size_t i = 0; i < first_ack.size(); ++i) {
      out.push_back(absl::ToDoubleSeconds(first_ack[i] - killed[i]));
    }
    return out;
  }
};

std::string Summary(std::vector<double> v) {
  if (v.empty()) return "none";
  std::sort(v.begin(), v.end());
  return absl::StrFormat("median %.2f s, p90 %.2f s, max %.2f s over %d", v[v.size() / 2],
                         v[std::min(v.size() - 1, v.size() * 9 / 10)], v.back(), int(v.size()));
}

// The README's failure: kill -9 of the database primary, ten times at random moments, while
// two nodes ingest from two clients each; a supervisor restarts the dead database node once
// the monitor has promoted the standby (it rejoins as the new standby).
TEST_F(PgFailoverTest, KillingTheDatabasePrimaryTenTimesLosesNoAcknowledgedFrame) {
  ASSERT_NO_FATAL_FAILURE(StartCluster(2));
  ASSERT_NO_FATAL_FAILURE(StartNodes());
  constexpr int kKills = 10;
  // 4 frames/s per client while the kills last (acknowledgements, so the streams, stop in
  // each failover), then the streams are stopped: each kill meets ingestion however long
  // the failovers take (a fixed 300 frames ran out before the tenth kill on a slow day).
  constexpr uint64_t kFrames = 100000;
  FirstAcks acks;
  StartClients(kFrames, absl::Milliseconds(250),
               [&](absl::Time sent, absl::Time acked) { acks.Ack(sent, acked); });
  std::mt19937 random(20261128);
  for (int k = 0; k < kKills; ++k) {
    absl::SleepFor(absl::Milliseconds(std::uniform_int_distribution<int>(300, 2000)(random)));
    for (int i = 0; i < kClients; ++i) ASSERT_TRUE(results_[i].ok());
    absl::StatusOr<int> primary = cluster_->Primary();
    ASSERT_TRUE(primary.ok()) << primary.status();
    ASSERT_TRUE(cluster_->Kill(*primary).ok());
    acks.Kill(absl::Now());
    absl::StatusOr<int> promoted = cluster_->WaitForPrimaryOtherThan(*primary, absl::Seconds(60));
    ASSERT_TRUE(promoted.ok()) << "kill " << k << ": " << promoted.status();
    ASSERT_TRUE(cluster_->StartNode(*primary).ok());
    absl::Status healthy = cluster_->WaitHealthy(absl::Seconds(120));
    ASSERT_TRUE(healthy.ok()) << "kill " << k << ": " << healthy;
    // Ingestion resumed before the next kill.
    ASSERT_TRUE(acks.WaitForAck(absl::Seconds(60))) << "no ack after kill " << k;
  }
  const std::vector<double> seconds = acks.Seconds();
  // Every stream was still running at the last kill and went on after it.
  std::vector<uint64_t> at_last_kill;
  for (int i = 0; i < kClients; ++i) at_last_kill.push_back(streamers_[i]->acked());
  const absl::Time resume_deadline = absl::Now() + absl::Seconds(60);
  for (int i = 0; i < kClients; ++i) {
    while (streamers_[i]->acked() <= at_last_kill[i] && absl::Now() < resume_deadline) {
      absl::SleepFor(absl::Milliseconds(100));
    }
    EXPECT_GT(streamers_[i]->acked(), at_last_kill[i]) << "client " << i << " stalled";
  }
  StopClients();
  ASSERT_NO_FATAL_FAILURE(JoinClients());
  std::printf("pg_failover_test: %d kills of the database primary; first new ack: %s\n", kKills,
              Summary(seconds).c_str());
  std::printf("pg_failover_test: node 0 store metrics:\n%s", StoreMetrics(0).c_str());
  ASSERT_EQ(seconds.size(), size_t(kKills));
  // Measured 6-8 s here on 2026-11-28 and 12-15 s alone on 2026-12-01 (2 s to call the
  // primary unhealthy, 3 s of demotion timeout, the promotion, and the killed node's return
  // as the synchronous standby that --store_durability=standby waits for), but median 23 s
  // and up to 37 s in the test command's release pass, beside the compute-bound tests and
  // the ASan build: the bound is for that loaded machine.
  for (double s : seconds) EXPECT_LT(s, 60.0);
  ASSERT_NO_FATAL_FAILURE(ExpectEveryFrameOnceAndAConsistentDatabase());
  const std::string metrics = StoreMetrics(0) + StoreMetrics(1);
  EXPECT_NE(metrics.find("skimap_store_reconnects_total"), std::string::npos) << metrics;
  EXPECT_EQ(metrics.find("skimap_store_reconnects_total 0\n"), std::string::npos) << metrics;
  EXPECT_NE(metrics.find("skimap_store_synchronous 1"), std::string::npos) << metrics;
}

// A primary cut off (SIGSTOP of its keeper and postgres) past the monitor's timeouts: the
// nodes go on through the promoted standby (three data nodes: the cluster keeps a
// synchronous standby), and once resumed, the old primary commits nothing a client could
// see: a write sent to it straight away does not succeed, and is not in the cluster after.
TEST_F(PgFailoverTest, APausedPrimaryIsReplacedAndItsWritesAreRefused) {
  ASSERT_NO_FATAL_FAILURE(StartCluster(3));
  ASSERT_NO_FATAL_FAILURE(StartNodes());
  absl::StatusOr<int> old = cluster_->Primary();
  ASSERT_TRUE(old.ok()) << old.status();
  ASSERT_TRUE(cluster_->Psql(*old, "CREATE TABLE probe (x int)").ok());
  constexpr uint64_t kFrames = 200;
  FirstAcks acks;
  StartClients(kFrames, absl::Milliseconds(100),
               [&](absl::Time sent, absl::Time acked) { acks.Ack(sent, acked); });
  absl::SleepFor(absl::Seconds(2));
  ASSERT_TRUE(cluster_->Pause(*old).ok());
  acks.Kill(absl::Now());
  absl::StatusOr<int> promoted = cluster_->WaitForPrimaryOtherThan(*old, absl::Seconds(60));
  ASSERT_TRUE(promoted.ok()) << promoted.status();
  ASSERT_TRUE(acks.WaitForAck(absl::Seconds(60))) << "no ack after the pause";
  const std::vector<double> seconds = acks.Seconds();
  ASSERT_EQ(seconds.size(), 1u);
  std::printf("pg_failover_test: primary paused; first new ack after %.2f s\n", seconds[0]);
  // About 10 s alone (2 s to call the primary unhealthy, 3 s of demotion timeout, the
  // statement deadline, the promotion); 32.7 s in CI's release pass on 2026-12-02, beside
  // the kill test's cluster and the compute-bound tests: the bound is for that loaded
  // machine, as the kill test's.
  EXPECT_LT(seconds[0], 60.0);
  absl::SleepFor(absl::Seconds(2));
  ASSERT_TRUE(cluster_->Resume(*old).ok());
  // Straight after resuming, the old primary still takes connections: its commit waits
  // for a standby that now follows another primary, and never answers success.
  absl::StatusOr<std::string> late =
      cluster_->Psql(*old, "INSERT INTO probe VALUES (1)", absl::Seconds(4));
  EXPECT_FALSE(late.ok()) << *late;
  ASSERT_NO_FATAL_FAILURE(JoinClients());
  absl::Status healthy = cluster_->WaitHealthy(absl::Seconds(120));
  ASSERT_TRUE(healthy.ok()) << healthy;
  absl::StatusOr<int> now = cluster_->Primary();
  ASSERT_TRUE(now.ok());
  EXPECT_NE(*now, *old);
  absl::StatusOr<std::string> probe = cluster_->Psql(*now, "SELECT count(*) FROM probe");
  ASSERT_TRUE(probe.ok()) << probe.status();
  EXPECT_EQ(absl::StripAsciiWhitespace(*probe), "0")
      << "the old primary's write reached the cluster";
  ASSERT_NO_FATAL_FAILURE(ExpectEveryFrameOnceAndAConsistentDatabase(kFrames));
}

// --store_durability=standby (the default with several hosts) on a server that does not
// replicate synchronously: skimapd refuses to start and says what to configure.
TEST_F(PgFailoverTest, ANodeThatMustReplicateRefusesALoneServer) {
  PostgresServer lone;
  ASSERT_TRUE(lone.Start().ok());
  SkimapdProcess node(SKIMAPD_PATH, {"--store=" + lone.Dsn("lone"), "--store_durability=standby"});
  const std::string log = ::testing::TempDir() + "/pg_failover_refused.log";
  node.set_log_file(log);
  EXPECT_EQ(node.Start().code(), absl::StatusCode::kFailedPrecondition);
  std::ifstream in(log);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("synchronous_standby_names is empty"), std::string::npos) << text;
  EXPECT_NE(text.find("--store_durability=primary"), std::string::npos) << text;
}

}  // namespace
}  // namespace skimap::testing
