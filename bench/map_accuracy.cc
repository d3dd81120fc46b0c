// map_accuracy: how close a SkiMap map lies to the surface an independent reconstruction
// finds in the same frames (docs/benchmarks.md, "Map accuracy"). A plain program,
// not a test; runs on any BOP scene or root, or TUM folder, with poses:
//
//   build/bench/bench/map_accuracy [--dataset=DIR] [--every=1 --limit=1000]
//       [--resolutions=0.01,0.02,0.05] [--edge_jumps=0,0.05] [--min_weights=1,2,4]
//       [--reference=DIR]
//
// Reference: Open3D 0.16's ScalableTSDFVolume (truncation 4 voxels, the same voxel edge,
// depth cut at max_depth 5 m) integrates every frame; its surface is ExtractPointCloud's
// zero crossings. With --reference, Open3D integrates that dataset's frames instead: the
// same views with other depth, e.g. a skimap-sim scene rendered again with
// --no-depth-noise, whose surface is then the scene's true one (same frame count and
// poses required). SkiMap: a map with the default options but `depth_edge_jump` (the
// flying-pixel filter, swept) fed the same decoded frames through the server's own frame
// stages (server/core/maps/frame_stages.h); its voxels are those a query returns at
// `min_voxel_weight` (swept). Per row:
//   accuracy      the fraction of SkiMap's voxel centres within a voxel diagonal
//                 (sqrt(3) * edge) of Open3D's surface;
//   completeness  the fraction of Open3D's surface points within a voxel diagonal of a
//                 SkiMap voxel centre;
//   median        SkiMap voxel centre -> nearest Open3D surface point, mm.
// Open3D's TSDF averages noise away along the rays, SkiMap keeps every observation, so a
// perfect SkiMap map does not reach 1.0 accuracy: the rows compare settings, the
// reference stays the same.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "absl/flags/flag.h"
#include "absl/flags/parse.h"
#include "absl/strings/str_split.h"
#include "bench/open3d_peer.h"
#include "bench/ycbv_frames.h"
#include "open3d/geometry/KDTreeFlann.h"
#include "open3d/geometry/PointCloud.h"
#include "server/core/maps/frame_stages.h"
#include "server/core/maps/map_config.h"
#include "server/core/maps/map_state.h"

ABSL_FLAG(std::string, dataset, SKIMAP_BENCH_YCBV_DIR, "a BOP scene or root, or a TUM folder");
ABSL_FLAG(int, every, 1, "every n-th frame");
ABSL_FLAG(int, limit, 1000, "at most this many frames");
ABSL_FLAG(std::string, resolutions, "0.01,0.02,0.05", "voxel edges, metres");
ABSL_FLAG(std::string, edge_jumps, "0,0.05", "depth_edge_jump values (0 = no filter)");
ABSL_FLAG(
    std::string, reference, "",
    "the same views with other depth (e.g. ideal) for Open3D's reference; default: --dataset");
ABSL_FLAG(std::string, min_weights, "1,2,4", "min_voxel_weight values of the query");

namespace skimap::bench {
namespace {

std::vector<double> Numbers(const std::string& list) {
  std::vector<double> out;
  for (absl::string_view s : absl::StrSplit(list, ',')) out.push_back(std::stod(std::string(s)));
  return out;
}

// Fraction of `from` within `radius` of a point of `to` (indexed by `tree`), and the
// median distance.
std::pair<double, double> Within(const std::vector<Eigen::Vector3d>& from,
                                 const open3d::geometry::KDTreeFlann& tree, double radius) {
  if (from.empty()) return {0, 0};
  size_t near = 0;
  std::vector<double> dist(from.size());
  std::vector<int> index(1);
  std::vector<double> d2(1);
  for (size_t i = 0; i < from.size(); ++i) {
    tree.SearchKNN(from[i], 1, index, d2);
    dist[i] = d2.empty() ? 1e9 : std::sqrt(d2[0]);
    near += dist[i] <= radius;
  }
  std::nth_element(dist.begin(), dist.begin() + dist.size() / 2, dist.end());
  return {double(near) / double(from.size()), dist[dist.size() / 2]};
}

}  // namespace
}  // namespace skimap::bench

int main(int argc, char** argv) {
  absl::ParseCommandLine(argc, argv);
  using namespace skimap;
  using namespace skimap::bench;
  const std::vector<RealFrame> real =
      LoadYcbvFrames(absl::GetFlag(FLAGS_dataset), size_t(absl::GetFlag(FLAGS_every)),
                     size_t(absl::GetFlag(FLAGS_limit)));
  std::vector<perception::RgbdFrame> frames;
  for (const RealFrame& f : real) frames.push_back(ToRgbdFrame(f));
  const std::string reference_dir = absl::GetFlag(FLAGS_reference);
  const std::vector<RealFrame> reference =
      reference_dir.empty() ? std::vector<RealFrame>{}
                            : LoadYcbvFrames(reference_dir, size_t(absl::GetFlag(FLAGS_every)),
                                             size_t(absl::GetFlag(FLAGS_limit)));
  if (!reference_dir.empty()) {
    bool same = reference.size() == real.size();
    for (size_t i = 0; same && i < real.size(); ++i) {
      same = real[i].api.pose().SerializeAsString() == reference[i].api.pose().SerializeAsString();
    }
    if (!same) {
      std::fprintf(stderr, "--reference: not the same frames and poses as --dataset\n");
      return 1;
    }
  }
  std::printf("## %s: %zu frames; reference: Open3D of %s\n\n",
              absl::GetFlag(FLAGS_dataset).c_str(), frames.size(),
              reference_dir.empty() ? "the same frames" : reference_dir.c_str());
  std::printf(
      "| voxel | depth_edge_jump | pixels dropped / frame | min_voxel_weight | SkiMap voxels | "
      "Open3D surface points | accuracy | completeness | median mm |\n"
      "|---|---|---|---|---|---|---|---|---|\n");
  ThreadPool pool(2);
  for (const double res : Numbers(absl::GetFlag(FLAGS_resolutions))) {
    // The reference.
    auto volume = NewVolume(res);
    for (const RealFrame& f : reference_dir.empty() ? real : reference) {
      const Open3dFrame o = ToOpen3d(f, 0, 5.0);
      volume->Integrate(*o.rgbd, o.intrinsic, o.extrinsic);
    }
    const std::shared_ptr<open3d::geometry::PointCloud> surface = volume->ExtractPointCloud();
    const open3d::geometry::KDTreeFlann surface_tree(*surface);
    const double diagonal = std::sqrt(3.0) * res;
    for (const double jump : Numbers(absl::GetFlag(FLAGS_edge_jumps))) {
      v1::MapOptions options;
      options.set_resolution(res);
      options.set_depth_edge_jump(jump);
      options.set_carve_free_space(false);  // the surface only
      absl::StatusOr<server::MapConfig> config = server::ResolveMapOptions(options);
      if (!config.ok()) {
        std::fprintf(stderr, "%s\n", config.status().ToString().c_str());
        return 1;
      }
      server::MapState state(*config, &pool);
      auto stages = server::MakeFrameStages(*config, Grid(res), &pool);
      size_t dropped = 0;
      for (const perception::RgbdFrame& f : frames) {
        dropped += stages[0]->Stage(f, server::FrameStage::kAdd).depth_edges;
        for (auto& s : stages) s->Apply(&state);
      }
      for (const double min_weight : Numbers(absl::GetFlag(FLAGS_min_weights))) {
        open3d::geometry::PointCloud ours;
        state.rgb.ForEach([&](const VoxelKey& k, const RGBWeightedVoxel& v) {
          if (v.Weight() < min_weight) return;
          const Point3 c = state.rgb.grid().Center(k);
          ours.points_.emplace_back(c.x, c.y, c.z);
        });
        const open3d::geometry::KDTreeFlann ours_tree(ours);
        const auto [accuracy, median] = Within(ours.points_, surface_tree, diagonal);
        const auto [completeness, unused] = Within(surface->points_, ours_tree, diagonal);
        std::printf("| %g cm | %g | %zu | %g | %zu | %zu | %.3f | %.3f | %.1f |\n", res * 100, jump,
                    dropped / std::max<size_t>(frames.size(), 1), min_weight, ours.points_.size(),
                    surface->points_.size(), accuracy, completeness, median * 1000);
        std::fflush(stdout);
      }
    }
  }
  return 0;
}
