// fleet_bench: a fleet of skimapd nodes on PostgreSQL (issue 14; docs/benchmarks.md,
// "Fleet"). A plain program, not a test; markdown tables on stdout, progress on stderr:
//
//   build/bench/bench/fleet_bench [--frames=80] [--streams=3] [--kills=20]
//       [--lease_ttl_ms=2000] [--parts=ingest,failover]
//
// Real processes throughout: a PostgreSQL 15 server from Debian's package started here
// (tests/common/postgres_server.h: loopback, fsync on, synchronous_commit on) and skimapd
// processes (tests/common/skimapd_process.h); clients are FleetStreamers
// (tests/common/fleet_streamer.h: StreamFrames, window 8, redirects, failover).
//
// 1. Ingestion: --streams streams of --frames frames each into as many maps, at the maximum
//    rate, for (a) one skimapd on SQLite (DATA_DIR/maps.sqlite, WAL, synchronous=FULL),
//    (b) one skimapd on PostgreSQL, (c) three skimapd nodes on one PostgreSQL, each map
//    created through (so owned by) node i mod n and streamed to its owner. Frames/s over
//    all streams, the ack latency (Send to ack) p50 / p99, and the CPU time per frame of
//    the skimapd processes and of the PostgreSQL server (/proc/PID/stat, the postmaster
//    and its backends), which is what a cluster of real machines scales by.
// 2. Failover: three nodes, one map streamed at 20 frames/s through a FleetStreamer;
//    --kills times: kill -9 the map's owner, time from the kill to the first new frame
//    acknowledged by another node, restart the killed node. Failover time is the lease
//    time (--lease_ttl_ms) plus the claim, the load and the client's retry.
//
// Frames: 640x480 depth (RAW_U16, 600 KiB; no colour) of the synthetic box scene from a
// view that changes each frame (the crash test's orbit). Maps: 5 cm voxels, every 2nd
// pixel integrated.
//
// Checks (a failure prints CHECK FAILED and the program exits 1): every frame of every
// stream confirmed; each map holds exactly --frames frames afterwards; in every failover
// round the map holds every frame acknowledged before the kill.
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "absl/flags/flag.h"
#include "absl/flags/parse.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_split.h"
#include "bench/fleet_common.h"
#include "tests/common/fleet_streamer.h"
#include "tests/common/postgres_server.h"
#include "tests/common/skimapd_process.h"
#include "tests/common/synthetic_scene.h"

ABSL_FLAG(int, frames, 80, "frames per stream (ingestion)");
ABSL_FLAG(int, streams, 3, "streams, one map each (ingestion)");
ABSL_FLAG(int, kills, 20, "failover rounds");
ABSL_FLAG(int, lease_ttl_ms, 2000, "skimapd --lease_ttl_ms of the nodes");
ABSL_FLAG(std::string, parts, "ingest,failover", "which parts to run");

namespace skimap::bench {
namespace {

using testing::FleetStreamer;
using testing::PostgresServer;
using testing::SkimapdProcess;

// The tables; stdout is stderr for everything else (the skimapd children print there).
std::FILE* g_out = stdout;

// CPU seconds (user + system) a process has used so far; 0 if it is gone.
double CpuSeconds(pid_t pid) {
  std::ifstream in(absl::StrCat("/proc/", pid, "/stat"));
  std::string line;
  if (!std::getline(in, line)) return 0;
  const size_t close = line.rfind(')');  // the command may hold spaces
  std::vector<std::string> f = absl::StrSplit(line.substr(close + 2), ' ');
  // Fields after the command: state is 0; utime and stime are 11 and 12.
  return (std::stod(f[11]) + std::stod(f[12])) / double(sysconf(_SC_CLK_TCK));
}

// CPU seconds of a PostgreSQL server: its postmaster and every backend it forked.
double PostgresCpuSeconds(const PostgresServer& pg) {
  std::ifstream pidfile(pg.data_dir() + "/postmaster.pid");
  pid_t postmaster = 0;
  pidfile >> postmaster;
  double total = CpuSeconds(postmaster);
  for (const auto& entry : std::filesystem::directory_iterator("/proc")) {
    const std::string name = entry.path().filename().string();
    if (name.find_first_not_of("0123456789") != std::string::npos) continue;
    std::ifstream in(entry.path() / "stat");
    std::string line;
    if (!std::getline(in, line)) continue;
    const size_t close = line.rfind(')');
    if (close == std::string::npos) continue;
    std::vector<std::string> f = absl::StrSplit(line.substr(close + 2), ' ');
    if (f.size() > 2 && std::stol(f[1]) == postmaster) total += CpuSeconds(std::stoi(name));
  }
  return total;
}

std::vector<std::unique_ptr<SkimapdProcess>> StartNodes(int n, const std::string& dsn) {
  std::vector<std::unique_ptr<SkimapdProcess>> nodes;
  for (int i = 0; i < n; ++i) {
    std::vector<std::string> flags = {"--snapshot_interval_s=5"};
    if (!dsn.empty()) {
      flags.push_back("--store=" + dsn);
      flags.push_back(absl::StrCat("--lease_ttl_ms=", absl::GetFlag(FLAGS_lease_ttl_ms)));
    }
    nodes.push_back(std::make_unique<SkimapdProcess>(SKIMAPD_PATH, flags));
    Check(nodes.back()->Start().ok(), "skimapd starts");
  }
  return nodes;
}

void Ingest(PostgresServer& pg) {
  const int frames = absl::GetFlag(FLAGS_frames), streams = absl::GetFlag(FLAGS_streams);
  std::fprintf(g_out,
               "### Ingestion: %d streams x %d frames, 640x480 depth, window 8, max rate\n\n",
               streams, frames);
  std::fprintf(
      g_out,
      "| store | nodes | frames/s | ack p50 ms | ack p99 ms | skimapd CPU ms/frame | PostgreSQL "
      "CPU ms/frame |\n|---|---|---|---|---|---|---|\n");
  struct Config {
    const char* name;
    bool postgres;
    int nodes;
  };
  int db = 0;
  for (const Config& c :
       {Config{"SQLite", false, 1}, Config{"PostgreSQL", true, 1}, Config{"PostgreSQL", true, 3}}) {
    std::fprintf(stderr, "fleet_bench: ingest, %s, %d node(s)\n", c.name, c.nodes);
    const std::string dsn = c.postgres ? pg.Dsn(absl::StrCat("ingest", ++db)) : "";
    auto nodes = StartNodes(c.nodes, dsn);
    std::vector<std::string> addresses;
    for (auto& n : nodes) addresses.push_back(n->address());
    for (int i = 0; i < streams; ++i) {
      auto client = client::MapClient::Connect(addresses[i % c.nodes]);
      Check(client->CreateMap(CreateRequest(absl::StrCat("s", i))).ok(), "CreateMap");
    }
    std::mutex mu;
    std::vector<double> latency_ms;
    const double pg_cpu_before = c.postgres ? PostgresCpuSeconds(pg) : 0;
    std::vector<double> node_cpu_before;
    for (auto& n : nodes) node_cpu_before.push_back(CpuSeconds(n->pid()));
    const absl::Time start = absl::Now();
    std::vector<std::thread> threads;
    for (int i = 0; i < streams; ++i) {
      threads.emplace_back([&, i] {
        const std::string map = absl::StrCat("maps/s", i);
        FleetStreamer s(
            addresses, map, [&](uint64_t q) { return Frame(map, q); }, 8);
        s.StartAt(i % c.nodes);
        s.OnAck([&](uint64_t, absl::Duration d) {
          std::lock_guard<std::mutex> lock(mu);
          latency_ms.push_back(absl::ToDoubleMilliseconds(d));
        });
        absl::Status done = s.Run(0, frames, absl::Now() + absl::Minutes(10));
        Check(done.ok(), absl::StrCat(map, ": ", done.ToString()));
      });
    }
    for (std::thread& t : threads) t.join();
    const double seconds = absl::ToDoubleSeconds(absl::Now() - start);
    double node_cpu = 0;
    for (size_t i = 0; i < nodes.size(); ++i)
      node_cpu += CpuSeconds(nodes[i]->pid()) - node_cpu_before[i];
    const double pg_cpu = c.postgres ? PostgresCpuSeconds(pg) - pg_cpu_before : 0;
    const int total = streams * frames;
    for (int i = 0; i < streams; ++i) {
      auto client = client::MapClient::Connect(addresses[0]);
      auto info = client->GetMap(absl::StrCat("maps/s", i));
      Check(info.ok() && info->stats().frames() == uint64_t(frames), "map holds every frame");
    }
    const std::string pg_ms = c.postgres ? absl::StrFormat("%.1f", 1e3 * pg_cpu / total) : "-";
    std::fprintf(g_out, "| %s | %d | %.1f | %.1f | %.1f | %.1f | %s |\n", c.name, c.nodes,
                 total / seconds, Percentile(latency_ms, 0.5), Percentile(latency_ms, 0.99),
                 1e3 * node_cpu / total, pg_ms.c_str());
    std::fflush(g_out);
  }
  std::fprintf(g_out, "\n");
}

void Failover(PostgresServer& pg) {
  const int kills = absl::GetFlag(FLAGS_kills);
  const int ttl_ms = absl::GetFlag(FLAGS_lease_ttl_ms);
  std::fprintf(stderr, "fleet_bench: failover, %d kills\n", kills);
  auto nodes = StartNodes(3, pg.Dsn("failover"));
  {
    auto client = client::MapClient::Connect(nodes[0]->address());
    Check(client->CreateMap(CreateRequest("f")).ok(), "CreateMap f");
  }
  const std::string map = "maps/f";
  std::vector<double> failover_ms;
  uint64_t next = 0;
  for (int round = 0; round < kills; ++round) {
    std::vector<std::string> addresses;
    for (auto& n : nodes) addresses.push_back(n->address());
    // The owner, as the store says.
    auto lister = client::MapClient::Connect(addresses[(round + 1) % 3]);
    auto maps = lister->ListAllMaps();
    Check(maps.ok() && maps->size() == 1, "ListMaps");
    const std::string owner = (*maps)[0].owner_address();
    size_t victim = 0;
    while (victim < 3 && addresses[victim] != owner) ++victim;
    if (victim == 3) victim = 0;  // no live owner yet: the stream below claims it
    std::mutex mu;
    absl::Time killed = absl::InfiniteFuture(), first = absl::InfiniteFuture();
    uint64_t acked = 0, highest = 0;
    FleetStreamer s(
        addresses, map, [&](uint64_t q) { return Frame(map, q); }, 8);
    s.StartAt(victim);
    s.OnAck([&](uint64_t q, absl::Duration) {
      std::lock_guard<std::mutex> lock(mu);
      ++acked;
      if (killed != absl::InfiniteFuture() && q > highest && first == absl::InfiniteFuture()) {
        first = absl::Now();
      }
      if (killed == absl::InfiniteFuture()) highest = std::max(highest, q);
    });
    const uint64_t from = next, end = next + 30;
    absl::Status done;
    std::thread streaming([&] { done = s.Run(from, end, absl::Now() + absl::Minutes(2)); });
    for (;;) {  // kill once 10 frames of this round are acknowledged
      {
        std::lock_guard<std::mutex> lock(mu);
        if (acked >= 10) {
          nodes[victim]->Kill();
          killed = absl::Now();
          break;
        }
      }
      absl::SleepFor(absl::Milliseconds(2));
    }
    streaming.join();
    Check(done.ok(), absl::StrCat("round ", round, ": ", done.ToString()));
    const double ms = absl::ToDoubleMilliseconds(first - killed);
    failover_ms.push_back(ms);
    auto info = client::MapClient::Connect(addresses[(victim + 1) % 3])->GetMap(map);
    Check(info.ok() && info->stats().frames() == end, "map holds every frame after failover");
    std::fprintf(stderr, "fleet_bench: round %d: failover %.0f ms\n", round + 1, ms);
    next = end;
    Check(nodes[victim]->Start().ok(), "restart the killed node");
  }
  std::fprintf(g_out, "### Failover: %d kills of the owner, lease %d ms, 3 nodes\n\n", kills,
               ttl_ms);
  std::fprintf(g_out, "| kills | min ms | median ms | p90 ms | max ms |\n|---|---|---|---|---|\n");
  std::fprintf(g_out, "| %d | %.0f | %.0f | %.0f | %.0f |\n\n", kills, Percentile(failover_ms, 0),
               Percentile(failover_ms, 0.5), Percentile(failover_ms, 0.9),
               Percentile(failover_ms, 1.0));
}

}  // namespace
}  // namespace skimap::bench

int main(int argc, char** argv) {
  absl::ParseCommandLine(argc, argv);
  // The tables go to the real stdout; the children's output (inherited fd 1) to stderr.
  skimap::bench::g_out = skimap::bench::ReportToStdout();
  skimap::testing::PostgresServer pg;
  skimap::bench::Check(pg.Start().ok(), "PostgreSQL starts");
  const std::string parts = absl::GetFlag(FLAGS_parts);
  if (parts.find("ingest") != std::string::npos) skimap::bench::Ingest(pg);
  if (parts.find("failover") != std::string::npos) skimap::bench::Failover(pg);
  return 0;
}
