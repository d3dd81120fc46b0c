// service_bench: the map service over loopback gRPC (issue 4; docs/benchmarks.md, "Map
// service"). A plain program, not a test:
//
//   build/bench/bench/service_bench [--frames=N] [--queries=N] [--worker_threads=N]
//
// 1. Ingestion: frames/s of StreamFrames (window 8) for one stream and for 4 concurrent
//    streams (each into its own map), 640x480 depth at 2 cm and 5 cm voxels, depth sent
//    raw, as PNG16 and as zstd. Mapping only (no colour, no carving).
// 2. Grid queries: p50/p99 latency of GetOccupancyGrid over a 20 m x 20 m region of a map
//    while 2 streams ingest into it.
// 3. The server's per-frame path without gRPC: decode, back-projection + batch, integration.
//
// Frames are ray-cast up front, along one of two trajectories (--trajectories):
//  - loop: 48 poses on a loop 6 m from the centre of an analytic 20 m x 20 m room (floor,
//    walls, 24 pillars and tables), 1.2 m above the floor. Frame k shows pose k mod 48, so
//    a run of 150 frames re-observes the room about three times: after the first lap most
//    of a frame's voxels are already in the map (the share of new voxels is printed).
//  - line: every frame a new pose, 7 m apart along a straight ~1 km aisle, looking
//    sideways at shelves and a wall 6 m away (about as many voxels per frame as the loop's
//    views): each frame's voxels are mostly new, so the map keeps growing (the cost of new
//    space, as on a long trajectory).
// Grid queries use the loop (a bounded map of the room). Floors (issue 4): >= 30 frames/s
// for one stream; grid query p99 < 50 ms under load.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "Eigen/Geometry"
#include "absl/flags/flag.h"
#include "absl/flags/parse.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "client/map_client.h"
#include "codec/image_codec.h"
#include "perception/frame_integrator.h"
#include "server/app/server.h"
#include "server/core/maps/frame_decode.h"
#include "skimap/skimap.h"
#include "tests/common/synthetic_scene.h"

ABSL_FLAG(int, frames, 150, "frames per ingestion run (per stream)");
ABSL_FLAG(int, queries, 200, "grid queries in the latency run");
ABSL_FLAG(int, worker_threads, 2, "skimapd integration threads");
ABSL_FLAG(std::string, trajectories, "loop,line",
          "ingestion trajectories: loop (48 poses reused) and/or line (a new pose per frame)");

namespace skimap::bench {
namespace {

using Clock = std::chrono::steady_clock;
double Seconds(Clock::duration d) { return std::chrono::duration<double>(d).count(); }

constexpr int kWidth = 640, kHeight = 480;
constexpr double kFx = 525, kFy = 525, kCx = 319.5, kCy = 239.5;
constexpr int kPoses = 48;

struct Box {
  Eigen::Vector3d min, max;
};

// The room: walls 10 cm thick at +-10 m, pillars and tables on a jittered lattice.
std::vector<Box> MakeRoom() {
  std::vector<Box> boxes = {{{-10.1, -10.1, 0}, {-10, 10.1, 3}},
                            {{10, -10.1, 0}, {10.1, 10.1, 3}},
                            {{-10.1, -10.1, 0}, {10.1, -10, 3}},
                            {{-10.1, 10, 0}, {10.1, 10.1, 3}}};
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> jitter(-1.0, 1.0);
  for (int i = 0; i < 24; ++i) {
    const double x = -7.5 + 3.0 * (i % 6) + jitter(rng), y = -7.5 + 3.0 * (i / 6) * 1.25;
    if (std::hypot(x, y) > 5.0 && std::hypot(x, y) < 7.0) continue;  // keep the loop clear
    const double h = i % 3 == 0 ? 2.5 : 0.75, s = i % 3 == 0 ? 0.3 : 0.8;
    boxes.push_back({{x - s / 2, y - s / 2, 0}, {x + s / 2, y + s / 2, h}});
  }
  return boxes;
}

double Cast(const Eigen::Vector3d& o, const Eigen::Vector3d& d, const std::vector<Box>& boxes) {
  double best = d.z() < 0 ? -o.z() / d.z() : std::numeric_limits<double>::infinity();
  for (const Box& b : boxes) {
    double t0 = 0, t1 = best;
    for (int a = 0; a < 3 && t0 <= t1; ++a) {
      if (std::abs(d[a]) < 1e-12) {
        if (o[a] < b.min[a] || o[a] > b.max[a]) t0 = t1 + 1;
        continue;
      }
      double ta = (b.min[a] - o[a]) / d[a], tb = (b.max[a] - o[a]) / d[a];
      if (ta > tb) std::swap(ta, tb);
      t0 = std::max(t0, ta);
      t1 = std::min(t1, tb);
    }
    if (t0 <= t1) best = std::min(best, t0);
  }
  return best;
}

// Pose k of the loop: radius 6 m, 1.2 m up, looking outwards-forwards and 15 degrees down.
Eigen::Isometry3d LoopPose(int k) {
  const double a = 2 * M_PI * k / kPoses;
  return testing::LookingAlong({6 * std::cos(a), 6 * std::sin(a), 1.2},
                               {std::cos(a + 0.9), std::sin(a + 0.9), -0.27});
}

// The line trajectory's world: an aisle along +x with a wall at y = 6 m and shelves of
// varying height in front of it, as long as `frames` poses need.
constexpr double kLineStep = 7.0;  // metres between poses; a frame spans ~7.3 m of wall
constexpr double kWallY = 6.0;
std::vector<Box> MakeAisle(int frames) {
  const double length = kLineStep * frames + 10;
  std::vector<Box> boxes = {{{-10, kWallY, 0}, {length, kWallY + 0.1, 3}}};
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(0, 1);
  for (double x = -8; x < length; x += 1.2 + u(rng)) {
    const double w = 0.4 + 0.6 * u(rng), depth = 0.3 + 0.4 * u(rng), h = 0.3 + 1.8 * u(rng);
    boxes.push_back({{x, kWallY - 0.05 - depth, 0}, {x + w, kWallY - 0.05, h}});
  }
  return boxes;
}

// Pose k of the line: (7 k, 0, 1.2), looking at the wall (+y) and 15 degrees down.
Eigen::Isometry3d LinePose(int k) {
  return testing::LookingAlong({kLineStep * k, 0, 1.2}, {0, 1, -0.27});
}

// The boxes within `reach` metres of x (in x): what a frame taken at x can see.
std::vector<Box> Near(const std::vector<Box>& boxes, double x, double reach) {
  std::vector<Box> out;
  for (const Box& b : boxes) {
    if (b.max.x() >= x - reach && b.min.x() <= x + reach) out.push_back(b);
  }
  return out;
}

perception::DepthImage Render(const Eigen::Isometry3d& pose, const std::vector<Box>& boxes) {
  perception::DepthImage depth{kWidth, kHeight, std::vector<uint16_t>(kWidth * kHeight, 0)};
  for (int v = 0; v < kHeight; ++v) {
    for (int u = 0; u < kWidth; ++u) {
      const Eigen::Vector3d ray((u - kCx) / kFx, (v - kCy) / kFy, 1);
      const double t = Cast(pose.translation(), pose.linear() * ray, boxes);
      if (t < 8.0) depth.pixels[v * kWidth + u] = uint16_t(std::lround(t * 1000));
    }
  }
  return depth;
}

// The poses of a trajectory; frame k is taken at poses[k % poses.size()].
struct Trajectory {
  std::string name;
  std::vector<Eigen::Isometry3d> poses;
};

struct Encoded {
  const char* name;
  v1::DepthEncoding encoding;
  std::vector<std::string> depth;  // one per pose
  const Trajectory* trajectory = nullptr;
};

v1::Frame MakeFrame(const std::string& map, uint64_t sequence, int frame_index,
                    const Encoded& enc) {
  v1::Frame f;
  f.set_map(map);
  f.set_sequence(sequence);
  const size_t pose_index = static_cast<size_t>(frame_index) % enc.trajectory->poses.size();
  const Eigen::Isometry3d& pose = enc.trajectory->poses[pose_index];
  const Eigen::Quaterniond q(pose.linear());
  auto* p = f.mutable_pose();
  p->mutable_rotation()->set_w(q.w());
  p->mutable_rotation()->set_x(q.x());
  p->mutable_rotation()->set_y(q.y());
  p->mutable_rotation()->set_z(q.z());
  p->mutable_translation()->set_x(pose.translation().x());
  p->mutable_translation()->set_y(pose.translation().y());
  p->mutable_translation()->set_z(pose.translation().z());
  auto* k = f.mutable_intrinsics();
  k->set_fx(kFx);
  k->set_fy(kFy);
  k->set_cx(kCx);
  k->set_cy(kCy);
  k->set_width(kWidth);
  k->set_height(kHeight);
  f.set_depth_encoding(enc.encoding);
  f.set_depth(enc.depth[pose_index]);
  f.set_depth_scale(0.001);
  return f;
}

void CreateMap(client::MapClient& client, const std::string& id, double resolution) {
  v1::CreateMapRequest request;
  request.set_map_id(id);
  request.mutable_options()->set_resolution(resolution);
  request.mutable_options()->set_max_depth(8.0);
  if (auto map = client.CreateMap(request); !map.ok()) {
    std::fprintf(stderr, "CreateMap %s: %s\n", id.c_str(), map.status().ToString().c_str());
    std::exit(1);
  }
}

// Streams `frames` frames into maps/{id}; returns the number acknowledged OK.
int Stream(client::MapClient& client, const std::string& id, int frames, uint64_t first_sequence,
           const Encoded& enc, const std::atomic<bool>* stop = nullptr) {
  std::unique_ptr<client::FrameStream> stream = client.OpenFrameStream({.window = 8});
  const std::string map = absl::StrCat("maps/", id);
  for (int i = 0; i < frames && !(stop && stop->load()); ++i) {
    if (!stream->Send(MakeFrame(map, first_sequence + i, int(first_sequence + i), enc)).ok()) break;
  }
  auto acks = stream->Finish();
  if (!acks.ok()) return 0;
  return int(std::count_if(acks->begin(), acks->end(),
                           [](const v1::FrameAck& a) { return a.code() == 0; }));
}

double Percentile(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, size_t(p * v.size()))];
}

}  // namespace
}  // namespace skimap::bench

int main(int argc, char** argv) {
  using namespace skimap;
  using namespace skimap::bench;
  absl::ParseCommandLine(argc, argv);
  const int frames = absl::GetFlag(FLAGS_frames);
  const std::vector<std::string> wanted = absl::StrSplit(absl::GetFlag(FLAGS_trajectories), ',');

  // The loop is always rendered: the grid queries run on the room it maps.
  std::vector<Trajectory> trajectories;
  std::vector<std::vector<Box>> worlds;
  trajectories.push_back({"loop", {}});
  for (int k = 0; k < kPoses; ++k) trajectories.back().poses.push_back(LoopPose(k));
  worlds.push_back(MakeRoom());
  // Line: enough poses that no stream wraps (4 streams send frames/2 from s * 7).
  const int line_poses = std::max(frames, 3 * 7 + frames / 2);
  trajectories.push_back({"line", {}});
  for (int k = 0; k < line_poses; ++k) trajectories.back().poses.push_back(LinePose(k));
  worlds.push_back(MakeAisle(line_poses));
  auto selected = [&](const Trajectory& t) {
    return std::find(wanted.begin(), wanted.end(), t.name) != wanted.end();
  };

  const perception::DepthCodec codecs[] = {perception::DepthCodec::kRawU16,
                                           perception::DepthCodec::kPng16,
                                           perception::DepthCodec::kZstd};
  std::vector<std::vector<Encoded>> encoded(trajectories.size());
  for (size_t t = 0; t < trajectories.size(); ++t) {
    const Trajectory& traj = trajectories[t];
    if (t > 0 && !selected(traj)) continue;
    std::printf("%s: rendering %zu poses (640x480)...\n", traj.name.c_str(), traj.poses.size());
    std::vector<perception::DepthImage> depth;
    size_t valid = 0;
    for (const Eigen::Isometry3d& pose : traj.poses) {
      depth.push_back(t == 0 ? Render(pose, worlds[t])
                             : Render(pose, Near(worlds[t], pose.translation().x(), 12)));
      valid += std::count_if(depth.back().pixels.begin(), depth.back().pixels.end(),
                             [](uint16_t d) { return d != 0; });
    }
    std::printf("%s: valid depth pixels per frame: %.0f of %d\n", traj.name.c_str(),
                double(valid) / depth.size(), kWidth * kHeight);
    encoded[t] = {{"raw", v1::DEPTH_ENCODING_RAW_U16, {}, &traj},
                  {"png16", v1::DEPTH_ENCODING_PNG16, {}, &traj},
                  {"zstd", v1::DEPTH_ENCODING_ZSTD, {}, &traj}};
    for (size_t e = 0; e < encoded[t].size(); ++e) {
      size_t bytes = 0;
      for (const auto& d : depth) {
        encoded[t][e].depth.push_back(*perception::EncodeDepth(codecs[e], d));
        bytes += encoded[t][e].depth.back().size();
      }
      std::printf("%s: depth %-5s %7.1f kB/frame\n", traj.name.c_str(), encoded[t][e].name,
                  bytes / 1024.0 / depth.size());
    }
  }
  const std::vector<Encoded>& loop = encoded[0];

  // How much of each frame is new space: frames 0..frames-1 of a stream, integrated in turn.
  std::printf(
      "\n## Workload: new voxels per frame (%d frames per stream, in-process)\n\n"
      "| trajectory | distinct poses | resolution | voxels per frame | new voxels per frame "
      "| new share |\n|---|---|---|---|---|---|\n",
      frames);
  for (size_t t = 0; t < trajectories.size(); ++t) {
    if (!selected(trajectories[t])) continue;
    for (double resolution : {0.02, 0.05}) {
      SkiMap<RGBWeightedVoxel> map({.resolution = resolution});
      VoxelBatch<RGBWeightedVoxel> batch;
      perception::IntegrationOptions io;
      io.max_depth = 8.0;
      double touched = 0;
      for (int k = 0; k < frames; ++k) {
        const v1::Frame frame = MakeFrame("maps/x", k, k, encoded[t][0]);
        absl::StatusOr<perception::RgbdFrame> decoded = server::DecodeFrame(frame);
        perception::BuildFrameBatch(*decoded, map.grid(), io, &batch, nullptr);
        touched += batch.size();
        map.Integrate(batch);
      }
      std::printf("| %s | %zu | %.0f cm | %.0f | %.0f | %.0f %% |\n", trajectories[t].name.c_str(),
                  std::min<size_t>(frames, trajectories[t].poses.size()), resolution * 100,
                  touched / frames, double(map.size()) / frames, 100.0 * map.size() / touched);
      std::fflush(stdout);
    }
  }

  server::Server::Options options;
  options.grpc.address = "127.0.0.1:0";
  options.maps.worker_threads = absl::GetFlag(FLAGS_worker_threads);
  options.maps.max_kept_frame_bytes = size_t{256} << 20;
  auto server = server::Server::Start(options);
  if (!server.ok()) {
    std::fprintf(stderr, "%s\n", server.status().ToString().c_str());
    return 1;
  }
  auto client = client::MapClient::Connect(absl::StrCat("127.0.0.1:", (*server)->grpc_port()));
  int map_counter = 0;

  std::printf(
      "\n## Ingestion over loopback gRPC (frames/s; 1 stream: %d frames; 4 streams: %d "
      "each)\n\nloop: frame k shows pose k mod %d (poses reused); line: a new pose per "
      "frame.\n\n",
      frames, frames / 2, kPoses);
  std::printf(
      "| trajectory | resolution | depth | 1 stream | 4 streams (total) |\n"
      "|---|---|---|---|---|\n");
  for (size_t t = 0; t < trajectories.size(); ++t) {
    if (!selected(trajectories[t])) continue;
    for (double resolution : {0.02, 0.05}) {
      for (const Encoded& enc : encoded[t]) {
        const std::string one = absl::StrCat("one", map_counter++);
        CreateMap(*client, one, resolution);
        Clock::time_point start = Clock::now();
        const int ok1 = Stream(*client, one, frames, 0, enc);
        const double fps1 = ok1 / Seconds(Clock::now() - start);
        std::vector<std::string> ids;
        for (int s = 0; s < 4; ++s) {
          ids.push_back(absl::StrCat("four", map_counter++));
          CreateMap(*client, ids.back(), resolution);
        }
        std::atomic<int> ok4{0};
        start = Clock::now();
        std::vector<std::thread> threads;
        for (int s = 0; s < 4; ++s) {
          threads.emplace_back([&, s] { ok4 += Stream(*client, ids[s], frames / 2, s * 7, enc); });
        }
        for (std::thread& t : threads) t.join();
        const double fps4 = ok4 / Seconds(Clock::now() - start);
        std::printf("| %s | %.0f cm | %s | %.1f | %.1f |\n", trajectories[t].name.c_str(),
                    resolution * 100, enc.name, fps1, fps4);
        std::fflush(stdout);
        for (const std::string& id : ids) (void)client->DeleteMap(absl::StrCat("maps/", id));
        (void)client->DeleteMap(absl::StrCat("maps/", one));
      }
    }
  }

  std::printf("\n## Occupancy grid of a 20 m x 20 m map while 2 streams ingest into it (loop)\n\n");
  std::printf(
      "| resolution | grid cells | queries | p50 ms | p99 ms | ingest frames/s | idle, "
      "in-process p50 ms | the same, keep_seen_through | occupied cells: cleared / kept |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|\n");
  for (double resolution : {0.05, 0.02}) {
    const std::string id = absl::StrCat("query", map_counter++);
    CreateMap(*client, id, resolution);
    Stream(*client, id, kPoses, 1000000, loop[2]);  // the whole loop: the room's extent
    std::atomic<bool> stop{false};
    std::atomic<int> ingested{0};
    std::vector<std::thread> streams;
    const Clock::time_point start = Clock::now();
    for (int s = 0; s < 2; ++s) {
      streams.emplace_back([&, s] {
        for (uint64_t round = 0; !stop.load(); ++round) {
          ingested += Stream(*client, id, 24, (s + 1) * 10000000 + round * 24, loop[2], &stop);
        }
      });
    }
    v1::GetOccupancyGridRequest request;
    request.set_map(absl::StrCat("maps/", id));
    request.mutable_region()->set_min_x(-10);
    request.mutable_region()->set_min_y(-10);
    request.mutable_region()->set_max_x(10);
    request.mutable_region()->set_max_y(10);
    std::vector<double> ms;
    size_t cells = 0;
    for (int q = 0; q < absl::GetFlag(FLAGS_queries); ++q) {
      const Clock::time_point t0 = Clock::now();
      auto grid = client->GetOccupancyGrid(request);
      ms.push_back(Seconds(Clock::now() - t0) * 1e3);
      if (!grid.ok()) {
        std::fprintf(stderr, "grid: %s\n", grid.status().ToString().c_str());
        return 1;
      }
      cells = grid->data().size();
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    stop = true;
    for (std::thread& t : streams) t.join();
    const double fps = ingested / Seconds(Clock::now() - start);
    // The same query on the core (no gRPC) with no ingestion: the grid computation itself.
    // Alternately with the seen-through rule (the default) and without it
    // (keep_seen_through): what clearing costs a query.
    std::vector<double> idle_ms, idle_keep_ms;
    size_t occupied = 0, occupied_kept = 0;
    for (int q = 0; q < 20; ++q) {
      for (bool keep : {false, true}) {
        request.set_keep_seen_through(keep);
        const Clock::time_point t0 = Clock::now();
        auto grid = (*server)->maps().GetOccupancyGrid(request);
        (keep ? idle_keep_ms : idle_ms).push_back(Seconds(Clock::now() - t0) * 1e3);
        if (grid.ok()) {
          (keep ? occupied_kept : occupied) =
              size_t(std::count(grid->data().begin(), grid->data().end(), char(100)));
        }
      }
    }
    std::printf("| %.0f cm | %zu | %zu | %.1f | %.1f | %.1f | %.1f | %.1f | %zu / %zu |\n",
                resolution * 100, cells, ms.size(), Percentile(ms, 0.5), Percentile(ms, 0.99), fps,
                Percentile(idle_ms, 0.5), Percentile(idle_keep_ms, 0.5), occupied, occupied_kept);
    std::fflush(stdout);
    (void)client->DeleteMap(absl::StrCat("maps/", id));
  }

  std::printf("\n## Per-frame path without gRPC (ms per frame, mean of the first %d frames)\n\n",
              kPoses);
  std::printf(
      "| trajectory | resolution | depth | decode | back-projection + batch | integrate |\n");
  std::printf("|---|---|---|---|---|---|\n");
  ThreadPool pool(absl::GetFlag(FLAGS_worker_threads));
  for (size_t tr = 0; tr < trajectories.size(); ++tr) {
    if (!selected(trajectories[tr])) continue;
    for (double resolution : {0.02, 0.05}) {
      for (const Encoded& enc : encoded[tr]) {
        SkiMap<RGBWeightedVoxel> map({.resolution = resolution, .pool = &pool});
        VoxelBatch<RGBWeightedVoxel> batch;
        perception::IntegrationOptions io;
        io.max_depth = 8.0;
        double decode = 0, project = 0, integrate = 0;
        for (int k = 0; k < kPoses; ++k) {
          const v1::Frame frame = MakeFrame("maps/x", k, k, enc);
          Clock::time_point t = Clock::now();
          absl::StatusOr<perception::RgbdFrame> decoded = server::DecodeFrame(frame);
          decode += Seconds(Clock::now() - t);
          t = Clock::now();
          perception::BuildFrameBatch(*decoded, map.grid(), io, &batch, &pool);
          project += Seconds(Clock::now() - t);
          t = Clock::now();
          map.Integrate(batch);
          integrate += Seconds(Clock::now() - t);
        }
        std::printf("| %s | %.0f cm | %s | %.2f | %.2f | %.2f |\n", trajectories[tr].name.c_str(),
                    resolution * 100, enc.name, decode * 1e3 / kPoses, project * 1e3 / kPoses,
                    integrate * 1e3 / kPoses);
      }
    }
  }
  return 0;
}
