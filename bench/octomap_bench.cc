// OctoMap (liboctomap-dev 1.9) side of the benchmarks. Inserts (occupied end points only,
// no rays: the same update SkiMap does): updateNode per point (`OctoMap`), OctoMap's own
// KeySet batch path (`OctoMapKeySet`), and the structure-only merged rows fed SkiMap's
// merged (key, weight) batch (`OctoMapLazy`); insertPointCloud with rays for reference.
// Queries: leaf / leaf_bbx iteration (OctoMap has no radius search, height map or
// occupancy grid: these are what a user writes on top of its iterators).
#include <octomap/octomap.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

#include "bench/bench_harness.h"
#include "bench/bench_register.h"

namespace skimap::bench {
namespace {

// How a frame's points reach the tree.
enum class OctoMapInsert {
  // updateNode(point, true) per point: how most users call OctoMap; every call also updates
  // (and prunes) the inner nodes on its path.
  kPerPoint,
  // OctoMap's own batch path for a point cloud's end points, as insertPointCloud builds it:
  // the points' keys into an octomap::KeySet (one entry per distinct voxel), then
  // updateNode(key, true, lazy_eval = true) per key and one updateInnerOccupancy(). Like
  // insertPointCloud, a voxel gets one hit per frame however many points fall in it.
  kKeySet,
};

template <OctoMapInsert kMode>
class OctoMapAdapter {
 public:
  static constexpr bool kStoresPoints = false;
  explicit OctoMapAdapter(double res) : tree_(res) {}

  void Insert(const Cloud& cloud) {
    if constexpr (kMode == OctoMapInsert::kPerPoint) {
      for (const PointF& p : cloud) tree_.updateNode(octomap::point3d(p.x, p.y, p.z), true);
    } else {
      keys_.clear();  // keeps its buckets: no rehash from the second frame on
      octomap::OcTreeKey k;
      for (const PointF& p : cloud) {
        if (tree_.coordToKeyChecked(octomap::point3d(p.x, p.y, p.z), k)) keys_.insert(k);
      }
      for (const octomap::OcTreeKey& key : keys_) tree_.updateNode(key, true, /*lazy_eval=*/true);
      tree_.updateInnerOccupancy();
    }
  }
  // Structure only, the fastest public write path for a merged batch: updateNode(key,
  // log-odds, lazy_eval = true) per distinct voxel, then one updateInnerOccupancy() for the
  // frame. The key is given (no coordinate conversion); the log-odds update is the batch
  // weight (points in the voxel) times the hit log-odds, which equals that many single
  // hits (all positive, so clamping at the threshold gives the same value); lazy_eval
  // skips the per-call inner-node update and pruning, done once per frame instead.
  // (updateNode still searches the key before descending: OctoMap's early abort for leaves
  // at the clamping threshold, part of its public API.)
  void InsertMerged(const VoxelBatch<WeightVoxel>& batch) {
    const float hit = tree_.getProbHitLog();
    for (const auto& item : batch.items()) {
      tree_.updateNode(ToOcKey(item.key), item.data.weight * hit, /*lazy_eval=*/true);
    }
    tree_.updateInnerOccupancy();
  }
  bool HasVoxel(const VoxelKey& k) const {
    const octomap::OcTreeNode* n = tree_.search(ToOcKey(k));  // a pruned leaf holds it too
    return n != nullptr && tree_.isNodeOccupied(n);
  }
  // Voxels whose centre is within r, from the leaves of the sphere's bounding box; a pruned
  // leaf (8^n equal voxels merged) contributes each of its voxels.
  size_t RadiusSearch(const PointF& c, double r) const {
    const octomap::point3d center(c.x, c.y, c.z);
    const octomap::point3d lo(c.x - r, c.y - r, c.z - r), hi(c.x + r, c.y + r, c.z + r);
    const double r2 = r * r;
    hits_.clear();
    for (auto it = tree_.begin_leafs_bbx(lo, hi), end = tree_.end_leafs_bbx(); it != end; ++it) {
      ForEachVoxel(it, [&](const octomap::point3d& p) {
        if ((p - center).norm_sq() <= r2) hits_.push_back({p, it->getLogOdds()});
      });
    }
    return hits_.size();
  }
  // Voxels with keys in the box's key range (as SkiMap's and OpenVDB's box queries count).
  size_t BoxCount(const PointF& lo, const PointF& hi) const {
    const octomap::OcTreeKey kmin = tree_.coordToKey(octomap::point3d(lo.x, lo.y, lo.z)),
                             kmax = tree_.coordToKey(octomap::point3d(hi.x, hi.y, hi.z));
    size_t n = 0;
    for (auto it = tree_.begin_leafs_bbx(kmin, kmax), end = tree_.end_leafs_bbx(); it != end;
         ++it) {
      if (it.getDepth() == tree_.getTreeDepth()) {
        ++n;  // a full-depth leaf from the bbx iterator lies in the key range
        continue;
      }
      ForEachVoxel(it, [&](const octomap::point3d& p) {
        const octomap::OcTreeKey k = tree_.coordToKey(p);
        bool inside = true;
        for (int a = 0; a < 3; ++a) inside = inside && k[a] >= kmin[a] && k[a] <= kmax[a];
        n += inside;
      });
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
  // Distinct voxels: a pruned leaf counts as the 8^n voxels it stands for.
  size_t Voxels() const {
    size_t n = 0;
    const unsigned max_depth = tree_.getTreeDepth();
    for (auto it = tree_.begin_leafs(), end = tree_.end_leafs(); it != end; ++it) {
      n += size_t{1} << (3 * (max_depth - it.getDepth()));
    }
    return n;
  }
  size_t LibBytes() const { return tree_.memoryUsage(); }
  // Caches the metric bounds (OctoMap's own cache, used by the rasters).
  void ReleaseScratch() {
    double x, y, z;
    tree_.getMetricMin(x, y, z);
  }

 private:
  // Our keys are floor(coord / res); OctoMap's add 2^15 (tree_max_val) to the same floor.
  static octomap::OcTreeKey ToOcKey(const VoxelKey& k) {
    constexpr int kOffset = 32768;
    return octomap::OcTreeKey(static_cast<octomap::key_type>(k.x + kOffset),
                              static_cast<octomap::key_type>(k.y + kOffset),
                              static_cast<octomap::key_type>(k.z + kOffset));
  }
  // fn(centre) for every voxel of a leaf: one, or all of a pruned leaf's.
  template <class It, class Fn>
  void ForEachVoxel(const It& it, Fn&& fn) const {
    if (it.getDepth() == tree_.getTreeDepth()) return fn(it.getCoordinate());
    const double res = tree_.getResolution();
    const int side = static_cast<int>(std::lround(it.getSize() / res));
    const octomap::point3d c = it.getCoordinate();
    const double x0 = c.x() - it.getSize() / 2, y0 = c.y() - it.getSize() / 2,
                 z0 = c.z() - it.getSize() / 2;
    for (int i = 0; i < side; ++i) {
      for (int j = 0; j < side; ++j) {
        for (int k = 0; k < side; ++k) {
          // Voxel centres exactly as keyToCoord computes them at full depth.
          fn(tree_.keyToCoord(tree_.coordToKey(
              octomap::point3d(x0 + (i + 0.5) * res, y0 + (j + 0.5) * res, z0 + (k + 0.5) * res))));
        }
      }
    }
  }
  struct Hit {
    octomap::point3d centre;
    float log_odds;
  };
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
  octomap::KeySet keys_;           // kKeySet: the frame's distinct keys, reused
  mutable std::vector<Hit> hits_;  // reused result buffer
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

const bool octomap_registered = [] {
  using PerPoint = OctoMapAdapter<OctoMapInsert::kPerPoint>;
  RegisterInserts<PerPoint>("OctoMap");
  RegisterInserts<OctoMapAdapter<OctoMapInsert::kKeySet>>("OctoMapKeySet");
  RegisterMergedInserts<OctoMapAdapter<OctoMapInsert::kKeySet>>("OctoMapLazy");
  RegisterRadius<PerPoint>("OctoMap");
  RegisterMapQueries<PerPoint>("OctoMap");
  RegisterMemory<PerPoint>("OctoMap");
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
