// pg_failover_bench: skimapd on a replicated PostgreSQL (docs/benchmarks.md, "A replicated
// store"). A plain program, not a test; markdown tables on stdout, progress
// on stderr:
//
//   build/bench/bench/pg_failover_bench [--kills=10] [--frames=150] [--streams=4]
//       [--appends=200] [--parts=commit,ingest,failover]
//
// Real processes throughout, in one run so the rows compare: one PostgreSQL server
// (tests/common/postgres_server.h: fsync on, synchronous_commit on) and pg_auto_failover
// clusters of two and three data nodes (scripts/pg_cluster.sh via tests/common/pg_cluster.h:
// a commit returns once a synchronous standby has flushed it), all on this machine.
//
// 1. Commit latency: --appends journal appends of one real-size frame record (640x480
//    depth, 600 KiB) through PostgresMapStore::AppendJournal, one at a time; p50 / p99.
// 2. Ingestion: two skimapd nodes, --streams streams (a map each, owned by node i mod 2) of
//    --frames 640x480 depth frames at the maximum rate (FleetStreamer, window 8); frames/s
//    over all streams and the ack latency p50 / p99.
// 3. Failover: two skimapd nodes ingesting from four clients at 5 frames/s each; --kills
//    times, at a random moment: kill -9 of the database primary (keeper and postgres), the
//    killed node restarted once the monitor promoted another (a supervisor's restart), the
//    cluster healthy again. Per kill, the time from the kill to the first acknowledgement
//    of a frame sent after it; median, p90, max. Beside it, the database alone: the time
//    from the kill to the first answer of a primary with a synchronous standby to a client
//    polling every 50 ms (what any client of the cluster waits for before a durable
//    commit), so the difference is what skimapd adds.
//
// Checks (a failure prints CHECK FAILED and exits 1): every frame of every stream
// confirmed, and each map then holds exactly its frames (the frame count the store
// reloads; pg_failover_test compares voxels).
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <mutex>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "absl/flags/flag.h"
#include "absl/flags/parse.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "bench/fleet_common.h"
#include "storage/postgres_map_store.h"
#include "tests/common/fleet_streamer.h"
#include "tests/common/pg_cluster.h"
#include "tests/common/postgres_server.h"
#include "tests/common/skimapd_process.h"
#include "tests/common/synthetic_scene.h"

ABSL_FLAG(int, kills, 10, "kills of the database primary per cluster (failover)");
ABSL_FLAG(int, frames, 150, "frames per stream (ingestion)");
ABSL_FLAG(int, streams, 4, "streams, one map each (ingestion)");
ABSL_FLAG(int, appends, 200, "journal appends timed (commit latency)");
ABSL_FLAG(std::string, parts, "commit,ingest,failover", "which parts to run");

namespace skimap::bench {
namespace {

using testing::FleetStreamer;
using testing::PgCluster;
using testing::PostgresServer;
using testing::SkimapdProcess;

std::FILE* g_out = stdout;  // the tables; stdout is stderr for the children

// The stores compared: a lone server, and clusters of two and three data nodes.
struct Topology {
  std::string name;
  std::string dsn;
  std::unique_ptr<PgCluster> cluster;  // null: the lone server
};

std::vector<Topology> Topologies(PostgresServer& lone, const std::string& db) {
  std::vector<Topology> out;
  out.push_back({"one server", lone.Dsn(db), nullptr});
  for (int n : {2, 3}) {
    auto cluster = std::make_unique<PgCluster>(n);
    absl::Status up = cluster->Start();
    Check(up.ok(), up.ToString());
    out.push_back({absl::StrCat(n, " nodes, synchronous"), cluster->uri(), std::move(cluster)});
  }
  return out;
}

void CommitLatency(std::vector<Topology>& topologies) {
  const int appends = absl::GetFlag(FLAGS_appends);
  const std::string record = Frame("maps/c", 0).SerializeAsString();
  std::fprintf(g_out,
               "### Commit latency: %d journal appends of a %zu KiB frame record, one at a time\n\n"
               "| store | p50 ms | p99 ms | max ms |\n|---|---|---|---|\n",
               appends, record.size() >> 10);
  for (Topology& t : topologies) {
    std::fprintf(stderr, "pg_failover_bench: commit latency, %s\n", t.name.c_str());
    auto store = storage::PostgresMapStore::Open(
        t.dsn, {.require_synchronous_standby = t.cluster != nullptr});
    Check(store.ok(), store.status().ToString());
    Check((*store)->CreateMap("commit", "o").ok(), "CreateMap commit");
    std::vector<double> ms;
    for (int i = 0; i < appends; ++i) {
      const absl::Time start = absl::Now();
      Check((*store)->AppendJournal("commit", {{storage::JournalRecord::kFrame, record}}).ok(),
            "AppendJournal");
      ms.push_back(absl::ToDoubleMilliseconds(absl::Now() - start));
    }
    std::fprintf(g_out, "| %s | %.2f | %.2f | %.2f |\n", t.name.c_str(), Percentile(ms, 0.5),
                 Percentile(ms, 0.99), Percentile(ms, 1.0));
    std::fflush(g_out);
  }
  std::fprintf(g_out, "\n");
}

std::vector<std::unique_ptr<SkimapdProcess>> StartNodes(const std::string& dsn) {
  std::vector<std::unique_ptr<SkimapdProcess>> nodes;
  for (int i = 0; i < 2; ++i) {
    nodes.push_back(std::make_unique<SkimapdProcess>(
        SKIMAPD_PATH,
        std::vector<std::string>{"--store=" + dsn, "--snapshot_interval_s=5", "--lease_ttl_ms=3000",
                                 "--store_failover_timeout_ms=60000"}));
    Check(nodes.back()->Start().ok(), "skimapd starts");
  }
  return nodes;
}

// Streams `frames` frames into each of `streams` new maps `prefix`i through the nodes;
// `paced` (while true) waits `pace` before each frame. Returns when all are confirmed.
void Stream(const std::vector<std::string>& addresses, const std::string& prefix, int streams,
            int frames, absl::Duration pace, const std::atomic<bool>& paced,
            const FleetStreamer::OnAckFn& on_ack) {
  for (int i = 0; i < streams; ++i) {
    auto client = client::MapClient::Connect(addresses[i % addresses.size()]);
    Check(client->CreateMap(CreateRequest(absl::StrCat(prefix, i))).ok(), "CreateMap");
  }
  std::vector<std::thread> threads;
  for (int i = 0; i < streams; ++i) {
    threads.emplace_back([&, i] {
      const std::string map = absl::StrCat("maps/", prefix, i);
      FleetStreamer s(
          addresses, map,
          [&](uint64_t q) {
            if (paced) absl::SleepFor(pace);
            return Frame(map, q);
          },
          8);
      s.StartAt(i % addresses.size());
      s.OnAck(on_ack);
      absl::Status done = s.Run(0, frames, absl::Now() + absl::Minutes(15));
      Check(done.ok(), absl::StrCat(map, ": ", done.ToString()));
    });
  }
  for (std::thread& t : threads) t.join();
  for (int i = 0; i < streams; ++i) {
    auto info = client::MapClient::Connect(addresses[0], {.timeout = absl::Seconds(60)})
                    ->GetMap(absl::StrCat("maps/", prefix, i));
    Check(info.ok() && info->stats().frames() == uint64_t(frames),
          absl::StrCat(prefix, i, " holds every frame once"));
  }
}

void Ingest(std::vector<Topology>& topologies) {
  const int frames = absl::GetFlag(FLAGS_frames), streams = absl::GetFlag(FLAGS_streams);
  std::fprintf(g_out,
               "### Ingestion: 2 skimapd nodes, %d streams x %d frames (640x480 depth), window 8, "
               "max rate\n\n| store | frames/s | ack p50 ms | ack p99 ms |\n|---|---|---|---|\n",
               streams, frames);
  int run = 0;
  for (Topology& t : topologies) {
    std::fprintf(stderr, "pg_failover_bench: ingest, %s\n", t.name.c_str());
    auto nodes = StartNodes(t.dsn);
    std::vector<std::string> addresses;
    for (auto& n : nodes) addresses.push_back(n->address());
    std::mutex mu;
    std::vector<double> latency_ms;
    const std::atomic<bool> unpaced{false};
    const absl::Time start = absl::Now();
    Stream(addresses, absl::StrCat("i", ++run, "_"), streams, frames, absl::ZeroDuration(), unpaced,
           [&](uint64_t, absl::Duration d) {
             std::lock_guard<std::mutex> lock(mu);
             latency_ms.push_back(absl::ToDoubleMilliseconds(d));
           });
    const double seconds = absl::ToDoubleSeconds(absl::Now() - start);
    std::fprintf(g_out, "| %s | %.1f | %.1f | %.1f |\n", t.name.c_str(), streams * frames / seconds,
                 Percentile(latency_ms, 0.5), Percentile(latency_ms, 0.99));
    std::fflush(g_out);
  }
  std::fprintf(g_out, "\n");
}

void Failover(std::vector<Topology>& topologies) {
  const int kills = absl::GetFlag(FLAGS_kills);
  std::fprintf(
      g_out,
      "### Failover: %d kills -9 of the database primary at random moments, 2 skimapd "
      "nodes ingesting from 4 clients at 5 frames/s each\n\n"
      "| cluster | kills | first new ack: median s | p90 s | max s | database alone: "
      "median s | p90 s | max s | frames, all kept |\n|---|---|---|---|---|---|---|---|---|\n",
      kills);
  std::mt19937 random(36);
  int run = 0;
  for (Topology& t : topologies) {
    if (t.cluster == nullptr) continue;
    std::fprintf(stderr, "pg_failover_bench: failover, %s\n", t.name.c_str());
    auto nodes = StartNodes(t.dsn);
    std::vector<std::string> addresses;
    for (auto& n : nodes) addresses.push_back(n->address());
    std::mutex mu;
    std::vector<absl::Time> killed, first;
    auto on_ack = [&](uint64_t, absl::Duration latency) {
      const absl::Time now = absl::Now();
      std::lock_guard<std::mutex> lock(mu);
      if (first.size() < killed.size() && now - latency > killed.back()) first.push_back(now);
    };
    constexpr int kStreams = 4;
    const int frames = 5 * 12 * kills + 50;  // outlasts the kills at 5 frames/s
    std::atomic<bool> paced{true};
    std::thread streaming([&] {
      Stream(addresses, absl::StrCat("f", ++run, "_"), kStreams, frames, absl::Milliseconds(200),
             paced, on_ack);
    });
    std::vector<double> database;
    for (int k = 0; k < kills; ++k) {
      absl::SleepFor(absl::Milliseconds(std::uniform_int_distribution<int>(500, 3000)(random)));
      absl::StatusOr<int> primary = t.cluster->Primary();
      Check(primary.ok(), "a primary");
      Check(t.cluster->Kill(*primary).ok(), "kill");
      const absl::Time at = absl::Now();
      {
        std::lock_guard<std::mutex> lock(mu);
        killed.push_back(at);
      }
      std::thread probe([&, at] {  // the database alone
        for (;;) {
          auto c =
              storage::PgConnection::Connect(t.dsn, {.statement_timeout = absl::Milliseconds(500)});
          if (c.ok()) {
            auto r = (*c)->Exec("SELECT current_setting('synchronous_standby_names') <> ''");
            if (r.ok() && r->Bool(0, 0)) break;
          }
          absl::SleepFor(absl::Milliseconds(50));
        }
        database.push_back(absl::ToDoubleSeconds(absl::Now() - at));
      });
      Check(t.cluster->WaitForPrimaryOtherThan(*primary, absl::Seconds(60)).ok(), "promotion");
      Check(t.cluster->StartNode(*primary).ok(), "restart");
      Check(t.cluster->WaitHealthy(absl::Seconds(120)).ok(), "healthy again");
      probe.join();
      for (int wait = 0; wait < 600; ++wait) {  // ingestion resumes before the next kill
        {
          std::lock_guard<std::mutex> lock(mu);
          if (first.size() == killed.size()) break;
        }
        absl::SleepFor(absl::Milliseconds(100));
      }
      std::fprintf(stderr, "pg_failover_bench: %s: kill %d done\n", t.name.c_str(), k + 1);
    }
    paced = false;
    streaming.join();
    std::vector<double> seconds;
    {
      std::lock_guard<std::mutex> lock(mu);
      Check(first.size() == killed.size(), "an ack after every kill");
      for (size_t i = 0; i < killed.size(); ++i) {
        seconds.push_back(absl::ToDoubleSeconds(first[i] - killed[i]));
      }
    }
    std::fprintf(g_out, "| %s | %d | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %d x %d |\n",
                 t.name.c_str(), kills, Percentile(seconds, 0.5), Percentile(seconds, 0.9),
                 Percentile(seconds, 1.0), Percentile(database, 0.5), Percentile(database, 0.9),
                 Percentile(database, 1.0), kStreams, frames);
    std::fflush(g_out);
  }
  std::fprintf(g_out, "\n");
}

}  // namespace
}  // namespace skimap::bench

int main(int argc, char** argv) {
  absl::ParseCommandLine(argc, argv);
  // The tables go to the real stdout; the children's output (inherited fd 1) to stderr.
  skimap::bench::g_out = skimap::bench::ReportToStdout();
  skimap::testing::PostgresServer lone;
  skimap::bench::Check(lone.Start().ok(), "PostgreSQL starts");
  std::vector<skimap::bench::Topology> topologies = skimap::bench::Topologies(lone, "bench");
  const std::string parts = absl::GetFlag(FLAGS_parts);
  if (parts.find("commit") != std::string::npos) skimap::bench::CommitLatency(topologies);
  if (parts.find("ingest") != std::string::npos) skimap::bench::Ingest(topologies);
  if (parts.find("failover") != std::string::npos) skimap::bench::Failover(topologies);
  return 0;
}
