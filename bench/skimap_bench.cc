// SkiMap side of the side-by-side benchmarks: batch integration (with and without the
// thread pool), integration of an already merged batch (structure only, the unit the peers'
// merged rows are fed) and the map's own query API. See bench_harness.h for the loops.
#include <cmath>
#include <memory>
#include <vector>

#include "bench/bench_harness.h"
#include "bench/bench_register.h"
#include "skimap/map_queries.h"
#include "skimap/skimap.h"

namespace skimap::bench {
namespace {

// SkiMap<WeightVoxel>; `kWorkers` threads in the pool besides the caller (0 = no pool).
// kCompact: query maps are compacted (SkiMap::Compact) once built, as a server does when a
// map is idle.
template <int kWorkers, bool kCompact = false>
class SkiMapAdapter {
 public:
  static constexpr bool kStoresPoints = false;
  explicit SkiMapAdapter(double res) : res_(res) { Reset(); }

  // A new, empty map; the batch (scratch a map worker keeps between frames) is kept.
  void Reset() {
    map_.reset();
    map_ = std::make_unique<SkiMap<WeightVoxel>>(
        SkiMap<WeightVoxel>::Options{.resolution = res_, .pool = Pool()});
  }

  // One frame: aggregate per voxel in a batch, then one tree update per distinct voxel;
  // with a pool, keys, sort and tree update all run on its threads.
  void Insert(const Cloud& cloud) {
    batch_.Clear();
    batch_.Reserve(cloud.size());
    batch_.AddPoints(
        map_->grid(), cloud.size(),
        [&](size_t i, Point3* p, WeightVoxel* d) {
          *p = {cloud[i].x, cloud[i].y, cloud[i].z};
          *d = WeightVoxel{1};
          return true;
        },
        Pool());
    batch_.Finalize(Pool());
    map_->Integrate(batch_);
  }
  // Structure only: the batch is already merged and finalized (same items the peers' merged
  // rows get); one tree update per distinct voxel.
  void InsertMerged(const VoxelBatch<WeightVoxel>& batch) { map_->Integrate(batch); }
  bool HasVoxel(const VoxelKey& k) const { return map_->Find(k).has_value(); }
  // Copies every hit (key and voxel) into a reused vector, as the PCL and nanoflann rows
  // fill theirs (indices and distances).
  size_t RadiusSearch(const PointF& c, double r) const {
    hits_.clear();
    map_->RadiusSearch({c.x, c.y, c.z}, r, [&](const VoxelKey& k, const WeightVoxel& v) {
      hits_.push_back({k, v});
    });
    return hits_.size();
  }
  size_t BoxCount(const PointF& lo, const PointF& hi) const {
    KeyBox box;
    if (!map_->grid().ToKey(lo.x, lo.y, lo.z, &box.min) ||
        !map_->grid().ToKey(hi.x, hi.y, hi.z, &box.max)) {
      return 0;
    }
    size_t n = 0;
    map_->ForEachInBox(box, [&](const VoxelKey&, const WeightVoxel&) { ++n; });
    return n;
  }
  double VisitAll() const {
    double sum = 0;
    map_->ForEach([&](const VoxelKey&, const WeightVoxel& v) { sum += v.weight; });
    return sum;
  }
  size_t HeightMap() const {
    const absl::StatusOr<skimap::HeightMap> hm = ComputeHeightMap(*map_, {});
    size_t known = 0;
    for (float h : hm->heights) known += !std::isnan(h);
    return known;
  }
  size_t OccupancyGrid() const {
    const absl::StatusOr<skimap::OccupancyGrid> grid = ComputeOccupancyGrid(*map_, {});
    size_t occupied = 0;
    for (int8_t c : grid->cells) {
      occupied += c == OccupancyGrid::kOccupied;
    }
    return occupied;
  }
  size_t Voxels() const { return map_->size(); }
  size_t LibBytes() const { return map_->MemoryUsage(); }
  void ReleaseScratch() {
    batch_ = {};
    hits_ = {};
    if constexpr (kCompact) map_->Compact();
  }

 private:
  static ThreadPool* Pool() {
    if constexpr (kWorkers == 0) {
      return nullptr;
    } else {
      static ThreadPool pool(kWorkers);
      return &pool;
    }
  }
  double res_;
  std::unique_ptr<SkiMap<WeightVoxel>> map_;
  VoxelBatch<WeightVoxel> batch_;
  struct Hit {
    VoxelKey key;
    WeightVoxel voxel;
  };
  mutable std::vector<Hit> hits_;  // reused result buffer
};

const bool skimap_registered = [] {
  RegisterInserts<SkiMapAdapter<0>>("SkiMap");
  RegisterInserts<SkiMapAdapter<1>>("SkiMapPool");
  RegisterMergedInserts<SkiMapAdapter<0>>("SkiMap");
  RegisterRadius<SkiMapAdapter<0>>("SkiMap");
  RegisterMapQueries<SkiMapAdapter<0>>("SkiMap");
  RegisterMemory<SkiMapAdapter<0>>("SkiMap");
  RegisterRadius<SkiMapAdapter<0, true>>("SkiMapCompact");
  RegisterMapQueries<SkiMapAdapter<0, true>>("SkiMapCompact");
  RegisterMemory<SkiMapAdapter<0, true>>("SkiMapCompact");
  return true;
}();

}  // namespace
}  // namespace skimap::bench
