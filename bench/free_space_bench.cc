// free_space_bench: what free-space evidence costs a frame (docs/benchmarks.md,
// "Free space"), beside OctoMap's insertPointCloud on the same rays in the same run. A plain
// program, not a test:
//
//   build/bench/bench/free_space_bench [--ycbv=DIR] [--dataset=DIR --every=15 --limit=60]
//       [--resolutions=0.01,0.02,0.05] [--reps=4] [--worker_threads=2] [--octomap=true]
//
// Frame sets: the 10 real frames of ycbv-0000, and optionally any BOP dataset with poses
// (a `skimap-sim` render: z up, floor at z = 0), every `every`-th frame, at most `limit`.
// Each frame set runs, per resolution and rep, into a fresh map with the default options
// and carving on (band 0.05-1.5 m, every 4th pixel's ray), frame after frame as a stream
// would, through the server's own frame stages (server/core/maps/frame_stages.h) on the
// server's ThreadPool: integration (back-projection, batch, SkiMap::Integrate) and free
// space (perception::BuildFreeSpaceBatch and its Integrate into the free volume), each
// timed from Stage to the end of Apply. Decoding is excluded from both (the frames are
// decoded once), so the ratio free / integration is the larger one a stream sees. Each rep
// also runs the same frames into a map without carving (before the carving map in even
// reps, after it in odd ones): "on / off - 1" is what free space adds to a whole frame, the
// pool's wake-ups and cache effects on integration included (a stage timed alone can look
// cheaper by leaving its cost in the next one). Use an even --reps.
//
// Peer: OctoMap 1.9's OcTree::insertPointCloud (octomap_server's per-frame update: free
// space along every ray in 3D, occupied end points), given the same rays (the end points
// of the pixels the free-space stage casts, in the world, and the camera centre) into a
// running tree per resolution, through its fastest path: end points merged per voxel
// first (discretize, as our fan merges rays) and inner nodes updated once after the last
// frame (lazy_eval; that update's time is shared out over the frames). Answers compared: the xy
// columns OctoMap ends up with a free voxel whose centre is in the band, against SkiMap's free
// columns (recall of OctoMap's by ours, and ours that OctoMap also knows, free or occupied, in the
// band). OctoMap carves in 3D and SkiMap in 2D columns, so they are close, not equal.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include "absl/container/flat_hash_set.h"
#include "absl/flags/flag.h"
#include "absl/flags/parse.h"
#include "absl/strings/str_split.h"
#include "bench/samples.h"
#include "bench/ycbv_frames.h"
#include "server/core/maps/frame_stages.h"
#include "server/core/maps/free_space_grid.h"
#include "server/core/maps/map_config.h"
#include "server/core/maps/map_state.h"

#ifdef SKIMAP_BENCH_OCTOMAP
#include <octomap/octomap.h>
#endif

ABSL_FLAG(std::string, ycbv, SKIMAP_BENCH_YCBV_DIR, "the ycbv-0000 BOP dataset root");
ABSL_FLAG(std::string, dataset, "", "another BOP dataset with poses (e.g. a skimap-sim render)");
ABSL_FLAG(int, every, 15, "--dataset: every n-th frame");
ABSL_FLAG(int, limit, 60, "--dataset: at most this many frames");
ABSL_FLAG(std::string, resolutions, "0.01,0.02,0.05", "voxel edges, metres");
ABSL_FLAG(int, reps, 4, "passes over each frame set per resolution (even: see above)");
ABSL_FLAG(int, worker_threads, 2, "the map's ThreadPool (skimapd's default)");
ABSL_FLAG(bool, octomap, true, "also run OctoMap's insertPointCloud on the same rays");

namespace skimap::bench {
namespace {

[[noreturn]] void Die(const std::string& what) {
  std::fprintf(stderr, "free_space_bench: %s\n", what.c_str());
  std::exit(1);
}

server::MapConfig Config(double resolution) {
  v1::MapOptions options;
  options.set_resolution(resolution);
  options.set_carve_free_space(true);
  absl::StatusOr<server::MapConfig> config = server::ResolveMapOptions(options);
  if (!config.ok()) Die(config.status().ToString());
  return *config;
}

struct Column {
  int32_t x, y;
  friend bool operator==(const Column&, const Column&) = default;
  template <typename H>
  friend H AbslHashValue(H h, const Column& c) {
    return H::combine(std::move(h), c.x, c.y);
  }
};

#ifdef SKIMAP_BENCH_OCTOMAP
// The rays the free-space stage casts: the stride lattice's valid pixels, in the world.
octomap::Pointcloud Rays(const perception::RgbdFrame& f, const server::MapConfig& config) {
  octomap::Pointcloud cloud;
  const int stride = config.carve_pixel_stride;
  const Eigen::Matrix3d rot = f.pose.rotation.toRotationMatrix();
  for (int v = 0; v < f.camera.height; v += stride) {
    for (int u = 0; u < f.camera.width; u += stride) {
      const uint16_t d = f.depth.pixels[size_t(v) * f.camera.width + u];
      const double z = d * f.depth_scale;
      if (d == 0 || z < config.integration.min_depth || z > config.integration.max_depth) continue;
      const Eigen::Vector3d p =
          f.pose.translation + rot * Eigen::Vector3d(z * (u - f.camera.cx) / f.camera.fx,
                                                     z * (v - f.camera.cy) / f.camera.fy, z);
      cloud.push_back(float(p.x()), float(p.y()), float(p.z()));
    }
  }
  return cloud;
}

// OctoMap's columns in the band: those with a free voxel, and those with any voxel.
void OctoMapColumns(const octomap::OcTree& tree, const server::MapConfig& config,
                    absl::flat_hash_set<Column>* free, absl::flat_hash_set<Column>* known) {
  const double res = config.resolution;
  for (auto it = tree.begin_leafs(), end = tree.end_leafs(); it != end; ++it) {
    const double size = it.getSize(), half = 0.5 * size;
    const octomap::point3d c = it.getCoordinate();
    const bool occupied = tree.isNodeOccupied(*it);
    const int n = std::max(1, int(std::lround(size / res)));
    for (int i = 0; i < n; ++i) {
      for (int j = 0; j < n; ++j) {
        for (int k = 0; k < n; ++k) {
          const double z = c.z() - half + (k + 0.5) * res;
          if (z < config.band_min_z || z > config.band_max_z) continue;
          const Column col{int32_t(std::floor((c.x() - half + (i + 0.5) * res) / res)),
                           int32_t(std::floor((c.y() - half + (j + 0.5) * res) / res))};
          known->insert(col);
          if (!occupied) free->insert(col);
        }
      }
    }
  }
}
#endif

void Run(const std::string& name, const std::vector<RealFrame>& real, ThreadPool& pool) {
  std::vector<perception::RgbdFrame> frames;
  for (const RealFrame& f : real) frames.push_back(ToRgbdFrame(f));
  std::printf("\n## %s: %zu frames\n\n", name.c_str(), frames.size());
  std::printf(
      "| voxel | integration ms/frame (median) | free space ms/frame (median) | free / "
      "integration (sum) | frame ms, carving off / on (median) | on / off - 1 (sums) | free "
      "columns | OctoMap insertPointCloud ms/frame | OctoMap / free space | OctoMap free "
      "columns we have | ours OctoMap knows |\n"
      "|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (absl::string_view r : absl::StrSplit(absl::GetFlag(FLAGS_resolutions), ',')) {
    const double res = std::stod(std::string(r));
    const server::MapConfig config = Config(res);
    server::MapConfig plain = config;  // the same map without carving
    plain.carve_free_space = false;
    Samples integrate, carve, off, on;
    double integrate_sum = 0, carve_sum = 0, off_sum = 0;
    size_t free_columns = 0;
    absl::flat_hash_set<Column> ours;
    // The whole frame without carving, before the same frames with it in even reps and
    // after them in odd ones (the first map of a run pays fresh pages): what free space adds,
    // the pool's wake-ups and cache effects on integration included.
    auto run_plain = [&] {
      server::MapState state(plain, &pool);
      auto stages = server::MakeFrameStages(plain, Grid(plain.resolution), &pool);
      if (stages.size() != 1) Die("expected the integration stage only");
      for (const perception::RgbdFrame& f : frames) {
        const auto t0 = Clock::now();
        stages[0]->Stage(f, server::FrameStage::kAdd);
        stages[0]->Apply(&state);
        const double ms = Ms(Clock::now() - t0);
        off.Add(ms);
        off_sum += ms;
      }
    };
    for (int rep = 0; rep < absl::GetFlag(FLAGS_reps); ++rep) {
      if (rep % 2 == 0) run_plain();
      {  // the carving map, gone before an odd rep's plain run
        server::MapState state(config, &pool);
        auto stages = server::MakeFrameStages(config, Grid(config.resolution), &pool);
        if (stages.size() != 2) Die("expected the integration and free-space stages");
        for (const perception::RgbdFrame& f : frames) {
          const auto t0 = Clock::now();
          stages[0]->Stage(f, server::FrameStage::kAdd);
          stages[0]->Apply(&state);
          const auto t1 = Clock::now();
          stages[1]->Stage(f, server::FrameStage::kAdd);
          stages[1]->Apply(&state);
          const auto t2 = Clock::now();
          integrate.Add(Ms(t1 - t0));
          carve.Add(Ms(t2 - t1));
          on.Add(Ms(t2 - t0));
          integrate_sum += Ms(t1 - t0);
          carve_sum += Ms(t2 - t1);
        }
        free_columns = server::CountFreeColumns(state.free);
        if (rep == 0) {
          state.free.ForEach([&](const VoxelKey& k, const FreeColumnsVoxel& block) {
            for (int32_t dx = 0; dx < FreeColumnsVoxel::kSide; ++dx) {
              for (int32_t dy = 0; dy < FreeColumnsVoxel::kSide; ++dy) {
                if (block.counts[FreeColumnsVoxel::Index(k.x + dx, k.y + dy)] > 0) {
                  ours.insert({k.x + dx, k.y + dy});
                }
              }
            }
          });
        }
      }
      if (rep % 2 == 1) run_plain();
    }
    std::printf("| %g cm | %.2f | %.2f | %.3f | %.2f / %.2f | %.3f | %zu |", res * 100,
                integrate.Median(), carve.Median(), carve_sum / integrate_sum, off.Median(),
                on.Median(), (integrate_sum + carve_sum) / off_sum - 1, free_columns);
#ifdef SKIMAP_BENCH_OCTOMAP
    if (absl::GetFlag(FLAGS_octomap)) {
      std::vector<octomap::Pointcloud> clouds;
      for (const perception::RgbdFrame& f : frames) clouds.push_back(Rays(f, config));
      octomap::OcTree tree(res);
      Samples peer;
      for (size_t i = 0; i < frames.size(); ++i) {
        const Eigen::Vector3d& o = frames[i].pose.translation;
        const auto t0 = Clock::now();
        // Its fastest path: end points merged per voxel first (discretize; our fan merges
        // rays too), inner nodes updated once at the end (lazy_eval).
        tree.insertPointCloud(clouds[i], octomap::point3d(float(o.x()), float(o.y()), float(o.z())),
                              /*maxrange=*/-1, /*lazy_eval=*/true, /*discretize=*/true);
        peer.Add(Ms(Clock::now() - t0));
      }
      const auto t0 = Clock::now();
      tree.updateInnerOccupancy();
      const double inner = Ms(Clock::now() - t0) / double(frames.size());  // per frame
      absl::flat_hash_set<Column> free, known;
      OctoMapColumns(tree, config, &free, &known);
      size_t have = 0, knows = 0;
      for (const Column& c : free) have += ours.contains(c);
      for (const Column& c : ours) knows += known.contains(c);
      const double peer_ms = peer.Median() + inner;
      std::printf(" %.2f | %.1fx | %.3f | %.3f |\n", peer_ms, peer_ms / carve.Median(),
                  free.empty() ? 0.0 : double(have) / double(free.size()),
                  ours.empty() ? 0.0 : double(knows) / double(ours.size()));
      continue;
    }
#endif
    std::printf(" - | - | - | - |\n");
  }
}

}  // namespace
}  // namespace skimap::bench

int main(int argc, char** argv) {
  absl::ParseCommandLine(argc, argv);
  using namespace skimap::bench;
  skimap::ThreadPool pool(size_t(absl::GetFlag(FLAGS_worker_threads)));
  Run("ycbv-0000 (real)", LoadYcbvFrames(absl::GetFlag(FLAGS_ycbv)), pool);
  if (const std::string d = absl::GetFlag(FLAGS_dataset); !d.empty()) {
    Run(d,
        LoadYcbvFrames(d, size_t(absl::GetFlag(FLAGS_every)), size_t(absl::GetFlag(FLAGS_limit))),
        pool);
  }
  return 0;
}
