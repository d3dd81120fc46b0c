// nanoflann (libnanoflann-dev 1.4) side of the benchmarks: a static kd-tree over the
// distinct voxel centres of each workload (so that it answers exactly what the voxel maps
// answer), queried with radiusSearch (unsorted, hits into a reused vector). A kd-tree cannot be
// updated, so a live map pays a rebuild per frame: BM_RadiusSurfaceRebuild_Nanoflann times rebuild
// + one query.
#include <memory>
#include <nanoflann.hpp>
#include <utility>
#include <vector>

#include "bench/bench_harness.h"
#include "bench/bench_register.h"

namespace skimap::bench {
namespace {

class NanoflannAdapter {
 public:
  static constexpr bool kStoresPoints = true;
  explicit NanoflannAdapter(double /*res*/) {}

  // Appends the points and rebuilds the index over all of them.
  void Insert(const Cloud& cloud) {
    points_.insert(points_.end(), cloud.begin(), cloud.end());
    Rebuild();
  }
  void Rebuild() {
    tree_ = std::make_unique<Tree>(3, dataset_, nanoflann::KDTreeSingleIndexAdaptorParams(10));
  }
  size_t RadiusSearch(const PointF& c, double r) const {
    const float q[3] = {c.x, c.y, c.z};
    nanoflann::SearchParams params;
    params.sorted = false;
    return tree_->radiusSearch(q, static_cast<float>(r * r), matches_, params);
  }
  size_t Voxels() const { return points_.size(); }
  size_t LibBytes() const {
    return tree_->usedMemory(*tree_) + points_.capacity() * sizeof(PointF);
  }
  void ReleaseScratch() { matches_ = {}; }

 private:
  struct Dataset {
    const Cloud* points;
    size_t kdtree_get_point_count() const { return points->size(); }
    float kdtree_get_pt(size_t i, size_t dim) const {
      const PointF& p = (*points)[i];
      return dim == 0 ? p.x : dim == 1 ? p.y : p.z;
    }
    template <class Box>
    bool kdtree_get_bbox(Box&) const {
      return false;
    }
  };
  using Tree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, Dataset>,
                                                   Dataset, 3, uint32_t>;
  Cloud points_;
  Dataset dataset_{&points_};
  std::unique_ptr<Tree> tree_;
  mutable std::vector<std::pair<uint32_t, float>> matches_;  // reused result buffer
};

void RunRebuildAndQuery(benchmark::State& state) {
  NanoflannAdapter index(kSurfaceResMm * 1e-3);
  index.Insert(VoxelCenters(Workload::kSurface, kSurfaceResMm));
  const Cloud& queries = QueryCentersFor(Workload::kSurface);
  const double r = state.range(0) * 1e-2;
  size_t i = 0, hits = 0;
  for (auto _ : state) {
    index.Rebuild();
    hits += index.RadiusSearch(queries[i++ % queries.size()], r);
  }
  state.counters["hits"] = static_cast<double>(hits) / static_cast<double>(state.iterations());
  state.counters["points"] = static_cast<double>(index.Voxels());
}

const bool nanoflann_registered = [] {
  RegisterRadius<NanoflannAdapter>("Nanoflann");
  RegisterMemory<NanoflannAdapter>("Nanoflann", /*big=*/false);
  benchmark::RegisterBenchmark("BM_RadiusSurfaceRebuild_Nanoflann", RunRebuildAndQuery)
      ->Arg(50)
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime();
  return true;
}();

}  // namespace
}  // namespace skimap::bench
