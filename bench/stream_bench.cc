// stream_bench: ingestion of real RGB-D frames over loopback gRPC (issue 15's stream
// floors; docs/benchmarks.md, "Ingestion over gRPC"). A plain program, not a test:
//
//   build/release/bench/stream_bench [--ycbv=DIR] [--frames=300] [--resolution=0.02]
//       [--window=8] [--reps=2] [--queries=200] [--data_dir=DIR]
//
// skimapd's composition root (server::Server, --worker_threads 2 as skimapd's default) runs
// in this process with its gRPC adapter on a loopback port; the client (client::FrameStream
// with --window frames in flight) sends through real sockets. Frames: the 10 real 640x480
// frames of ycbv-0000, encoded once per codec (RVL or PNG16 depth, JPEG q90 colour); frame k
// is moved 10 m along x, so every frame lands in new space. The client copies a pre-encoded
// frame and sets its pose before sending (no encoding in the timed loop; a robot encodes on
// its own CPU). Journal off: maps in memory. Journal on: maps.sqlite under --data_dir (WAL,
// synchronous=FULL: each frame's record is fsynced before its ack; snapshots every 10 s, as
// skimapd's default).
//
// 1. The disk under --data_dir: fsyncs/s overwriting 4 kB; appends/s of a frame-sized record
//    (write + fdatasync, the journal's pattern) and the MB/s that makes; sequential write
//    MB/s (256 MB, one fsync).
// 2. One stream, per codec, journal off and on: frames/s acknowledged (first send to last
//    ack), ack latency p50/p99 (from the Send call, so it includes waiting for the window).
// 3. Four streams into four maps, zstd + JPEG (the client library's default), journal off
//    and on: total and slowest
//    stream's frames/s.
// 4. A 20 m x 20 m GetOccupancyGrid while two streams ingest into the same map at full
//    speed (zstd + JPEG): the map is first filled with 1600 frames on a 0.5 m lattice over
//    the region, then
//    two streams send frames of new space (the lattice again, 3 m higher per pass) while
//    --queries rounds of grid queries run 5 ms apart, each round one with raw data and one
//    with zstd data (data_encoding; the client library decompresses it, inside the timed
//    call; both answer the same grid, checked first); p50/p99 per encoding, the bytes on the
//    wire, and the frames/s meanwhile.
//
// Runs 2 and 3 repeat --reps times, journal off and on interleaved; each cell is the best
// repetition (the shared machine's noise only slows runs down).
#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "absl/flags/flag.h"
#include "absl/flags/parse.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_split.h"
#include "bench/ycbv_frames.h"
#include "client/frame_stream.h"
#include "client/map_client.h"
#include "server/app/malloc_tuning.h"
#include "server/app/server.h"

ABSL_FLAG(std::string, ycbv, SKIMAP_BENCH_YCBV_DIR, "the ycbv-0000 BOP dataset root");
ABSL_FLAG(int, frames, 300, "frames per stream in runs 2 and 3");
ABSL_FLAG(double, resolution, 0.02, "voxel edge, metres");
ABSL_FLAG(int, window, 8, "frames in flight per stream");
ABSL_FLAG(int, reps, 2, "repetitions of runs 2 and 3 (best kept)");
ABSL_FLAG(int, queries, 200, "grid queries in run 4");
ABSL_FLAG(int, idle_queries, 50, "grid queries in run 4 before the streams start");
ABSL_FLAG(int, ingest_nice, 5, "skimapd --ingest_nice of the server");
ABSL_FLAG(int, robot_nice, 0,
          "niceness of run 4's two streaming threads (robots stand-ins; their CPU is not the "
          "server's)");
ABSL_FLAG(std::string, sections, "disk,streams,grid",
          "which runs: disk (1), streams (2, 3), grid (4)");
ABSL_FLAG(std::string, data_dir, "",
          "where the journal-on server keeps maps.sqlite and the "
          "disk is measured (default: a fresh directory under /var/tmp)");

namespace skimap::bench {
namespace {

using Clock = std::chrono::steady_clock;
constexpr size_t kLattice = 1600;  // frames of one pass over the grid's region (run 4)
double Seconds(Clock::duration d) { return std::chrono::duration<double>(d).count(); }
double Ms(Clock::duration d) { return Seconds(d) * 1e3; }

[[noreturn]] void Die(const std::string& what) {
  std::fprintf(stderr, "stream_bench: %s\n", what.c_str());
  std::exit(1);
}

double Percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, size_t(p * double(v.size())))];
}

// 1. The disk.
struct Disk {
  double overwrite_fsyncs_per_s = 0, appends_per_s = 0, append_mb_per_s = 0,
         sequential_mb_per_s = 0;
};
Disk MeasureDisk(const std::string& dir, size_t record_bytes) {
  Disk out;
  const std::string path = dir + "/disk_probe";
  int fd = open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
  if (fd < 0) Die("cannot write in " + dir);
  std::string block(4096, 'x');
  int ops = 0;
  Clock::time_point start = Clock::now();
  while (Seconds(Clock::now() - start) < 2) {
    if (pwrite(fd, block.data(), block.size(), 0) != ssize_t(block.size()) || fdatasync(fd) != 0) {
      Die("disk probe write failed");
    }
    ++ops;
  }
  out.overwrite_fsyncs_per_s = ops / Seconds(Clock::now() - start);
  const std::string record(record_bytes, 'r');
  ops = 0;
  start = Clock::now();
  while (Seconds(Clock::now() - start) < 3) {
    if (write(fd, record.data(), record.size()) != ssize_t(record.size()) || fdatasync(fd) != 0) {
      Die("disk probe append failed");
    }
    ++ops;
  }
  const double append_s = Seconds(Clock::now() - start);
  out.appends_per_s = ops / append_s;
  out.append_mb_per_s = double(ops) * double(record_bytes) / append_s / 1e6;
  if (ftruncate(fd, 0) != 0) Die("disk probe truncate failed");
  const std::string chunk(size_t{1} << 20, 's');
  start = Clock::now();
  for (int i = 0; i < 256; ++i) {
    if (write(fd, chunk.data(), chunk.size()) != ssize_t(chunk.size())) Die("disk write failed");
  }
  if (fsync(fd) != 0) Die("disk fsync failed");
  out.sequential_mb_per_s = 256.0 * double(chunk.size()) / 1e6 / Seconds(Clock::now() - start);
  close(fd);
  std::filesystem::remove(path);
  return out;
}

struct Run {
  int acked = 0;
  double seconds = 0;
  std::vector<double> ack_ms;
  double fps() const { return seconds > 0 ? acked / seconds : 0; }
};

// Streams frames [0, count) of `frames` (moved by shift(k)) into `map` on one StreamFrames
// call, until `stop` if given; every ack must be OK.
Run StreamInto(client::MapClient& client, const std::string& map, const EncodedFrames& frames,
               size_t count, uint64_t first_sequence, const std::function<Shift(size_t)>& shift,
               int window, const std::atomic<bool>* stop = nullptr, size_t first_frame = 0) {
  std::mutex mu;
  std::vector<Clock::time_point> sent(count);
  Run run;
  std::string error;
  auto stream = client.OpenFrameStream(
      {.window = window,
       .on_ack =
           [&](const v1::FrameAck& ack) {
             std::lock_guard<std::mutex> lock(mu);
             if (ack.code() != 0) {
               error = absl::StrCat("frame ", ack.sequence(), ": ", ack.message());
               return;
             }
             run.ack_ms.push_back(Ms(Clock::now() - sent[ack.sequence() - first_sequence]));
           }},
      map);
  const Clock::time_point start = Clock::now();
  size_t k = 0;
  for (; k < count && !(stop != nullptr && stop->load()); ++k) {
    const v1::Frame f = frames.Make(first_frame + k, map, first_sequence + k, shift(k));
    {
      std::lock_guard<std::mutex> lock(mu);
      sent[k] = Clock::now();
    }
    if (absl::Status s = stream->Send(f); !s.ok()) Die("send: " + s.ToString());
  }
  absl::StatusOr<std::vector<v1::FrameAck>> acks = stream->Finish();
  run.seconds = Seconds(Clock::now() - start);
  if (!acks.ok()) Die("stream: " + acks.status().ToString());
  if (!error.empty()) Die(error);
  run.acked = int(acks->size());
  if (size_t(run.acked) != k) Die("frames went unacknowledged");
  return run;
}

void CreateMap(client::MapClient& client, const std::string& id, double resolution) {
  v1::CreateMapRequest request;
  request.set_map_id(id);
  request.mutable_options()->set_resolution(resolution);
  if (auto map = client.CreateMap(request); !map.ok()) Die(map.status().ToString());
}

struct Server {
  std::unique_ptr<server::Server> server;
  std::unique_ptr<client::MapClient> client;
};
Server StartServer(const std::string& maps_db) {
  server::Server::Options options;
  options.grpc.address = "127.0.0.1:0";
  options.maps_db_path = maps_db;
  options.maps.ingest_nice = absl::GetFlag(FLAGS_ingest_nice);
  auto s = server::Server::Start(options);
  if (!s.ok()) Die(s.status().ToString());
  Server out{*std::move(s), nullptr};
  out.client = client::MapClient::Connect(absl::StrCat("127.0.0.1:", out.server->grpc_port()));
  return out;
}

void Main() {
  const std::vector<RealFrame> real = LoadYcbvFrames(absl::GetFlag(FLAGS_ycbv));
  const double res = absl::GetFlag(FLAGS_resolution);
  const int window = absl::GetFlag(FLAGS_window);
  const size_t count = size_t(absl::GetFlag(FLAGS_frames));
  std::string dir = absl::GetFlag(FLAGS_data_dir);
  if (dir.empty()) {
    dir = absl::StrCat("/var/tmp/stream_bench_", getpid());
  }
  std::filesystem::create_directories(dir);
  const EncodedFrames zstd(real, kZstdJpeg), rvl(real, kRvlJpeg), png(real, kPng16Jpeg);
  const Codec* codecs[] = {&kZstdJpeg, &kRvlJpeg, &kPng16Jpeg};
  const EncodedFrames* encoded[] = {&zstd, &rvl, &png};
  auto new_space = [](size_t k) { return Shift{.x = 10.0 * double(k)}; };
  std::printf("stream_bench: %zu ycbv frames 640x480, %.0f cm, window %d, %zu frames per stream\n",
              real.size(), res * 100, window, count);
  std::printf("frame message: zstd + JPEG %.0f kB, RVL + JPEG %.0f kB, PNG16 + JPEG %.0f kB\n",
              zstd.mean_bytes() / 1e3, rvl.mean_bytes() / 1e3, png.mean_bytes() / 1e3);

  const std::vector<std::string> sections = absl::StrSplit(absl::GetFlag(FLAGS_sections), ',');
  auto want = [&](const char* name) {
    return std::find(sections.begin(), sections.end(), name) != sections.end();
  };
  if (want("disk")) {
    const Disk disk = MeasureDisk(dir, size_t(zstd.mean_bytes()));
    std::printf(
        "\n### The disk under %s\n\n| 4 kB overwrite + fdatasync | %.0f kB record append + "
        "fdatasync | that append rate | sequential write (256 MB + fsync) |\n|---|---|---|---|\n"
        "| %.0f /s | %.0f /s | %.0f MB/s | %.0f MB/s |\n",
        dir.c_str(), zstd.mean_bytes() / 1e3, disk.overwrite_fsyncs_per_s, disk.appends_per_s,
        disk.append_mb_per_s, disk.sequential_mb_per_s);
    std::fflush(stdout);
  }

  if (want("streams")) {
    // 2 and 3, journal off (index 0) and on (1), best of reps.
    constexpr int kCodecs = std::size(codecs);
    Run one[kCodecs][2], four_total[2];
    double four_slowest[2] = {0, 0};
    for (int rep = 0; rep < absl::GetFlag(FLAGS_reps); ++rep) {
      for (int journal = 0; journal < 2; ++journal) {
        const std::string db = absl::StrCat(dir, "/maps_", rep, ".sqlite");
        Server s = StartServer(journal ? db : "");
        for (int c = 0; c < kCodecs; ++c) {
          const std::string id = absl::StrCat("one", c);
          CreateMap(*s.client, id, res);
          Run r = StreamInto(*s.client, "maps/" + id, *encoded[c], count, 1, new_space, window);
          if (r.fps() > one[c][journal].fps()) one[c][journal] = std::move(r);
        }
        std::vector<Run> runs(4);
        std::vector<std::thread> threads;
        for (int i = 0; i < 4; ++i) CreateMap(*s.client, absl::StrCat("four", i), res);
        const Clock::time_point start = Clock::now();
        for (int i = 0; i < 4; ++i) {
          threads.emplace_back([&, i] {
            runs[i] = StreamInto(*s.client, absl::StrCat("maps/four", i), zstd, count, 1, new_space,
                                 window);
          });
        }
        for (std::thread& t : threads) t.join();
        Run total;
        total.seconds = Seconds(Clock::now() - start);
        double slowest = 1e9;
        for (const Run& r : runs) {
          total.acked += r.acked;
          slowest = std::min(slowest, r.fps());
        }
        if (total.fps() > four_total[journal].fps()) {
          four_total[journal] = total;
          four_slowest[journal] = slowest;
        }
        s.server.reset();
        std::filesystem::remove(db), std::filesystem::remove(db + "-wal"),
            std::filesystem::remove(db + "-shm");
      }
    }
    std::printf(
        "\n### One stream, new space, %.0f cm, %zu frames, %d in flight (best of %d)\n\n"
        "| codec | journal | frames/s | ack p50 ms | ack p99 ms | journal MB/s |\n"
        "|---|---|---|---|---|---|\n",
        res * 100, count, window, absl::GetFlag(FLAGS_reps));
    for (int c = 0; c < kCodecs; ++c) {
      for (int journal = 0; journal < 2; ++journal) {
        const Run& r = one[c][journal];
        std::printf(
            "| %s | %s | %.1f | %.1f | %.1f | %s |\n", codecs[c]->name, journal ? "on" : "off",
            r.fps(), Percentile(r.ack_ms, 0.5), Percentile(r.ack_ms, 0.99),
            journal ? absl::StrFormat("%.1f", r.fps() * encoded[c]->mean_bytes() / 1e6).c_str()
                    : "-");
      }
    }
    std::printf(
        "\n### Four streams into four maps, zstd + JPEG, %zu frames each (best of %d)\n\n"
        "| journal | total frames/s | slowest stream frames/s | journal MB/s "
        "|\n|---|---|---|---|\n",
        count, absl::GetFlag(FLAGS_reps));
    for (int journal = 0; journal < 2; ++journal) {
      std::printf(
          "| %s | %.1f | %.1f | %s |\n", journal ? "on" : "off", four_total[journal].fps(),
          four_slowest[journal],
          journal
              ? absl::StrFormat("%.1f", four_total[journal].fps() * zstd.mean_bytes() / 1e6).c_str()
              : "-");
    }
    std::fflush(stdout);
  }

  // 4. The grid under ingestion (journal off).
  if (want("grid")) {
    Server s = StartServer("");
    // Where each of the frames lands on its own (the sequence's camera moves, so their
    // world boxes differ): one map per frame.
    struct Box {
      double cx, cy, min_z;
    };
    std::vector<Box> boxes;
    for (size_t i = 0; i < real.size(); ++i) {
      const std::string id = absl::StrCat("probe", i);
      CreateMap(*s.client, id, res);
      StreamInto(
          *s.client, "maps/" + id, zstd, 1, 1, [](size_t) { return Shift{}; }, window, nullptr, i);
      absl::StatusOr<v1::Map> probe = s.client->GetMap("maps/" + id);
      if (!probe.ok()) Die(probe.status().ToString());
      const v1::Box3& b = probe->stats().bounds();
      boxes.push_back(
          {(b.min().x() + b.max().x()) / 2, (b.min().y() + b.max().y()) / 2, b.min().z()});
    }
    // Copy k of a pass: frame k mod 10 centred on lattice point (k mod 40, k / 40 mod 40),
    // 0.5 m apart over the 20 m x 20 m region around the origin, its lowest voxel 25 cm below
    // z = 0 (its table in the grid's default floor band, -0.3 .. 0.05 m, objects in the
    // obstacle band above). One frame spans more than 0.5 m in x and y, so every column of
    // the region holds voxels. Pass p = k / 1600 is p * 3 m higher.
    auto lattice = [&boxes](size_t k) {
      const Box& b = boxes[k % boxes.size()];
      return Shift{.x = -9.75 + 0.5 * double(k % 40) - b.cx,
                   .y = -9.75 + 0.5 * double((k / 40) % 40) - b.cy,
                   .z = -0.25 - b.min_z + 3.0 * double(k / kLattice)};
    };
    CreateMap(*s.client, "grid", res);
    StreamInto(*s.client, "maps/grid", zstd, kLattice, 1, lattice, window);
    absl::StatusOr<v1::Map> filled = s.client->GetMap("maps/grid");
    if (!filled.ok()) Die(filled.status().ToString());
    const v1::Box3& fb = filled->stats().bounds();
    std::printf(
        "\ngrid map: %zu frames on the lattice, %llu voxels in x %.2f..%.2f, y %.2f..%.2f, "
        "z %.2f..%.2f m\n",
        kLattice, static_cast<unsigned long long>(filled->stats().voxels()), fb.min().x(),
        fb.max().x(), fb.min().y(), fb.max().y(), fb.min().z(), fb.max().z());
    v1::GetOccupancyGridRequest request;
    request.set_map("maps/grid");
    request.mutable_region()->set_min_x(-10);
    request.mutable_region()->set_min_y(-10);
    request.mutable_region()->set_max_x(10);
    request.mutable_region()->set_max_y(10);
    v1::GetOccupancyGridRequest zstd_request = request;
    zstd_request.set_data_encoding(v1::GRID_ENCODING_ZSTD);
    const v1::GetOccupancyGridRequest* const requests[2] = {&request, &zstd_request};
    const char* const encoding_names[2] = {"raw", "zstd"};
    // Both encodings answer the same grid (the client library decompresses zstd).
    {
      auto raw = s.client->GetOccupancyGrid(request);
      auto packed = s.client->GetOccupancyGrid(zstd_request);
      if (!raw.ok() || !packed.ok()) Die("grid query failed");
      if (raw->data() != packed->data()) Die("the zstd grid differs from the raw one");
    }
    std::vector<double> idle[2];
    for (int q = 0; q < absl::GetFlag(FLAGS_idle_queries); ++q) {
      for (int e = 0; e < 2; ++e) {
        const Clock::time_point t0 = Clock::now();
        if (auto g = s.client->GetOccupancyGrid(*requests[e]); !g.ok()) {
          Die(g.status().ToString());
        }
        idle[e].push_back(Ms(Clock::now() - t0));
      }
    }
    // The same query inside the server (no gRPC): the grid's own cost, cached and not.
    std::vector<double> inside;
    for (int q = 0; q < absl::GetFlag(FLAGS_idle_queries); ++q) {
      const Clock::time_point t0 = Clock::now();
      if (auto g = s.server->maps().GetOccupancyGrid(request); !g.ok()) Die(g.status().ToString());
      inside.push_back(Ms(Clock::now() - t0));
    }
    std::printf("in-process, no writes between queries: p50 %.2f ms, max %.2f ms\n",
                Percentile(inside, 0.5), Percentile(inside, 1.0));
    std::atomic<bool> stop{false};
    std::vector<Run> runs(2);
    std::vector<std::thread> streams;
    const Clock::time_point start = Clock::now();
    for (int i = 0; i < 2; ++i) {
      streams.emplace_back([&, i] {
        SetThreadNice(absl::GetFlag(FLAGS_robot_nice));
        // Stream i sends passes 1 + i, 3 + i, ...: always new space, inside the region.
        auto shift = [&](size_t k) {
          Shift sh = lattice(k % kLattice);
          sh.z += 3.0 * double(1 + i + 2 * (k / kLattice));
          return sh;
        };
        runs[i] = StreamInto(*s.client, "maps/grid", zstd, 1000000, 1000000 * (i + 1), shift,
                             window, &stop);
      });
    }
    // Each round: the grid over gRPC raw and zstd (in turns first), and every other round
    // inside the server (no gRPC: how much of the time is the grid's, and zstd's).
    std::vector<double> ms[2], in_server[2];
    size_t cells = 0, occupied = 0, known = 0, wire_bytes[2] = {0, 0};
    for (int q = 0; q < absl::GetFlag(FLAGS_queries); ++q) {
      if (q % 2 == 1) {
        const int e = (q / 2) % 2;
        const Clock::time_point t0 = Clock::now();
        absl::StatusOr<v1::OccupancyGrid> g = s.server->maps().GetOccupancyGrid(*requests[e]);
        in_server[e].push_back(Ms(Clock::now() - t0));
        if (!g.ok()) Die(g.status().ToString());
        wire_bytes[e] = g->data().size();
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
      }
      for (int k = 0; k < 2; ++k) {
        const int e = (q + k) % 2;
        const Clock::time_point t0 = Clock::now();
        absl::StatusOr<v1::OccupancyGrid> grid = s.client->GetOccupancyGrid(*requests[e]);
        ms[e].push_back(Ms(Clock::now() - t0));
        if (!grid.ok()) Die(grid.status().ToString());
        cells = grid->data().size();
        occupied = size_t(std::count(grid->data().begin(), grid->data().end(), char(100)));
        known = cells - size_t(std::count(grid->data().begin(), grid->data().end(), char(-1)));
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
      }
    }
    stop = true;
    for (std::thread& t : streams) t.join();
    const double seconds = Seconds(Clock::now() - start);
    const int ingested = runs[0].acked + runs[1].acked;
    absl::StatusOr<v1::Map> grid_map = s.client->GetMap("maps/grid");
    std::printf(
        "\n### 20 m x 20 m occupancy grid at %.0f cm while two streams ingest into the map\n\n"
        "%zu cells (%zu known, %zu occupied), %llu map voxels at the end, ingestion meanwhile "
        "%.1f frames/s (both streams)\n\n"
        "| data_encoding | bytes on the wire | queries | gRPC p50 ms | p99 | max | inside the "
        "server p50 / p99 ms | idle gRPC p50 / p99 ms |\n"
        "|---|---|---|---|---|---|---|---|\n",
        res * 100, cells, known, occupied,
        grid_map.ok() ? static_cast<unsigned long long>(grid_map->stats().voxels()) : 0ULL,
        ingested / seconds);
    for (int e = 0; e < 2; ++e) {
      std::printf("| %s | %zu | %zu | %.1f | %.1f | %.1f | %.1f / %.1f | %.1f / %.1f |\n",
                  encoding_names[e], wire_bytes[e], ms[e].size(), Percentile(ms[e], 0.5),
                  Percentile(ms[e], 0.99), Percentile(ms[e], 1.0), Percentile(in_server[e], 0.5),
                  Percentile(in_server[e], 0.99), Percentile(idle[e], 0.5),
                  Percentile(idle[e], 0.99));
    }
  }
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace skimap::bench

int main(int argc, char** argv) {
  skimap::server::TuneMallocForServer();  // as skimapd
  absl::ParseCommandLine(argc, argv);
  skimap::bench::Main();
  return 0;
}
