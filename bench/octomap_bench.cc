// OctoMap (liboctomap-dev 1.9) side of the benchmarks: OcTree::updateNode per point (no
// rays, the same occupied-only update SkiMap does), insertPointCloud with rays for
// reference, and leaf / leaf_bbx iteration for queries (OctoMap has no radius search,
// height map or occupancy grid: these are what a user writes on top of its iterators).
#include <octomap/octomap.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

#include "bench/bench_harness.h"
#include "bench/bench_register.h"

namespace skimap::bench {
namespace {

class OctoMapAdapter {
 public:
  static constexpr bool kStoresPoints = false;
  explicit OctoMapAdapter(double res) : tree_(res) {}

  void Insert(const Cloud& cloud) {
    for (const PointF& p : cloud) tree_.updateNode(octomap::point3d(p.x, p.y, p.z), true);
  }
  size_t RadiusCount(const PointF& c, double r) const {
    const octomap::point3d center(c.x, c.y, c.z);
    const octomap::point3d lo(c.x - r, c.y - r, c.z - r), hi(c.x + r, c.y + r, c.z + r);
    const double r2 = r * r;
    size_t n = 0;
    for (auto it = tree_.begin_leafs_bbx(lo, hi), end = tree_.end_leafs_bbx(); it != end; ++it) {
      const octomap::point3d d = it.getCoordinate() - center;
      n += d.norm_sq() <= r2;
    }
    return n;
  }
  size_t BoxCount(const PointF& lo, const PointF& hi) const {
    size_t n = 0;
    for (auto it = tree_.begin_leafs_bbx(octomap::point3d(lo.x, lo.y, lo.z),
                                         octomap::point3d(hi.x, hi.y, hi.z)),
              end = tree_.end_leafs_bbx();
         it != end; ++it) {
      ++n;
    }
    return n;
  }
  double VisitAll() const {
    double sum = 0;
    for (auto it = tree_.begin_leafs(), end = tree_.end_leafs(); it != end; ++it) {
      sum += it->getLogOdds();
    }
    return sum;
  }
  // Top occupied leaf centre per (x, y) cell over the tree's bounds; NaN unknown.
  size_t HeightMap() const {
    Raster r = MakeRaster();
    std::vector<float> heights(r.cells(), std::nanf(""));
    for (auto it = tree_.begin_leafs(), end = tree_.end_leafs(); it != end; ++it) {
      if (!tree_.isNodeOccupied(*it)) continue;
      float& h = heights[r.Index(it.getX(), it.getY())];
      const float z = static_cast<float>(it.getZ());
      if (std::isnan(h) || z > h) h = z;
    }
    size_t known = 0;
    for (float h : heights) known += !std::isnan(h);
    return known;
  }
  // Same semantics as skimap::ComputeOccupancyGrid with its default band.
  size_t OccupancyGrid() const {
    Raster r = MakeRaster();
    std::vector<int8_t> cells(r.cells(), -1);
    for (auto it = tree_.begin_leafs(), end = tree_.end_leafs(); it != end; ++it) {
      const double z = it.getZ();
      if (z < -0.3 || z > 1.5 || !tree_.isNodeOccupied(*it)) continue;
      int8_t& c = cells[r.Index(it.getX(), it.getY())];
      c = std::max<int8_t>(c, z >= 0.05 ? 100 : 0);
    }
    size_t occupied = 0;
    for (int8_t c : cells) occupied += c == 100;
    return occupied;
  }
  size_t Voxels() const { return tree_.getNumLeafNodes(); }
  size_t LibBytes() const { return tree_.memoryUsage(); }
  // Caches the metric bounds (OctoMap's own cache, used by the rasters).
  void ReleaseScratch() {
    double x, y, z;
    tree_.getMetricMin(x, y, z);
  }
  octomap::OcTree& tree() { return tree_; }

 private:
  struct Raster {
    double x0, y0, inv;
    size_t w, h;
    size_t cells() const { return w * h; }
    size_t Index(double x, double y) const {
      const size_t i = std::min(w - 1, static_cast<size_t>((x - x0) * inv));
      const size_t j = std::min(h - 1, static_cast<size_t>((y - y0) * inv));
      return j * w + i;
    }
  };
  Raster MakeRaster() const {
    double x0, y0, z0, x1, y1, z1;
    tree_.getMetricMin(x0, y0, z0);
    tree_.getMetricMax(x1, y1, z1);
    const double inv = 1.0 / tree_.getResolution();
    return {x0, y0, inv, static_cast<size_t>(std::ceil((x1 - x0) * inv)),
            static_cast<size_t>(std::ceil((y1 - y0) * inv))};
  }
  octomap::OcTree tree_;
};

// insertPointCloud with rays from the camera centre (free space carving): for reference.
void RunInsertRays(benchmark::State& state, bool real) {
  const std::vector<Cloud>& frames = real ? YcbvFrames() : RoomFrameList();
  if (frames.empty()) {
    state.SkipWithError(("no frames: " + YcbvError()).c_str());
    return;
  }
  std::vector<octomap::Pointcloud> clouds(frames.size());
  for (size_t f = 0; f < frames.size(); ++f) {
    for (const PointF& p : frames[f]) clouds[f].push_back(p.x, p.y, p.z);
  }
  auto origin = [&](size_t f) {
    const PointF o = real ? YcbvOrigins()[f] : RoomOrigin();
    return octomap::point3d(o.x, o.y, o.z);
  };
  std::unique_ptr<octomap::OcTree> tree;
  size_t i = 0, points = 0;
  for (auto _ : state) {
    state.PauseTiming();  // a fresh tree per frame; the old one's destruction is not timed
    tree.reset();
    tree = std::make_unique<octomap::OcTree>(state.range(0) * 1e-3);
    state.ResumeTiming();
    const size_t f = i++ % frames.size();
    tree->insertPointCloud(clouds[f], origin(f));
    points += clouds[f].size();
  }
  state.SetItemsProcessed(static_cast<int64_t>(points));
  state.counters["points"] = static_cast<double>(points) / static_cast<double>(state.iterations());
}

const bool registered = [] {
  RegisterInserts<OctoMapAdapter>("OctoMap");
  RegisterRadius<OctoMapAdapter>("OctoMap");
  RegisterMapQueries<OctoMapAdapter>("OctoMap");
  RegisterMemory<OctoMapAdapter>("OctoMap");
  benchmark::RegisterBenchmark("BM_InsertRoom_OctoMapRays",
                               [](benchmark::State& st) { RunInsertRays(st, false); })
      ->Arg(50)
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime();
  benchmark::RegisterBenchmark("BM_InsertYcbv_OctoMapRays",
                               [](benchmark::State& st) { RunInsertRays(st, true); })
      ->Arg(20)
      ->Arg(50)
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime();
  return true;
}();

}  // namespace
}  // namespace skimap::bench
