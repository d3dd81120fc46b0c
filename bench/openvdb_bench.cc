// OpenVDB (libopenvdb-dev 10) side of the benchmarks: a FloatGrid written through its
// caching ValueAccessor, one modifyValue (value += 1, voxel set active) per point, or (the
// merged rows) one modifyValue (value += weight) per distinct voxel of the batch; queries
// probe the leaves a box or sphere overlaps, visit-all and the rasters iterate active voxels.
#include <openvdb/openvdb.h>

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include "bench/bench_harness.h"
#include "bench/bench_register.h"

namespace skimap::bench {
namespace {

class OpenVdbAdapter {
 public:
  static constexpr bool kStoresPoints = false;
  explicit OpenVdbAdapter(double res)
      : grid_((Init(), openvdb::FloatGrid::create(0.0f))),
        acc_(grid_->getAccessor()),
        res_(res),
        inv_(1.0 / res) {}

  // Whole pipeline: one modifyValue per point through the grid's caching accessor
  // (consecutive image points mostly fall in the accessor's cached leaf).
  void Insert(const Cloud& cloud) {
    for (const PointF& p : cloud) {
      acc_.modifyValue(Key(p.x, p.y, p.z), [](float& v) { v += 1.0f; });
    }
  }
  // Structure only, the fastest public write path for a merged batch: one
  // ValueAccessor::modifyValue (value += weight, voxel set active) per distinct voxel. The
  // accessor caches the last leaf and internal nodes, and the batch is sorted by (x, y, z),
  // so runs of keys in one 8^3 leaf skip the tree descent; modifyValue is one lookup (a
  // getValue + setValue pair would be two). setValue alone would be wrong in steady state,
  // where the voxel already holds a weight.
  void InsertMerged(const VoxelBatch<WeightVoxel>& batch) {
    for (const auto& item : batch.items()) {
      const float w = item.data.weight;
      acc_.modifyValue(openvdb::Coord(item.key.x, item.key.y, item.key.z),
                       [w](float& v) { v += w; });
    }
  }
  bool HasVoxel(const VoxelKey& k) const {
    return grid_->getConstAccessor().isValueOn(openvdb::Coord(k.x, k.y, k.z));
  }
  // Copies every active voxel whose centre is within r (coordinate and value) into a reused
  // vector.
  size_t RadiusSearch(const PointF& c, double r) const {
    const double r2 = r * r;
    hits_.clear();
    ForEachInBox(Key(c.x - r, c.y - r, c.z - r), Key(c.x + r, c.y + r, c.z + r),
                 [&](const openvdb::Coord& k, float v) {
                   const double dx = (k.x() + 0.5) * res_ - c.x, dy = (k.y() + 0.5) * res_ - c.y,
                                dz = (k.z() + 0.5) * res_ - c.z;
                   if (dx * dx + dy * dy + dz * dz <= r2) hits_.push_back({k, v});
                 });
    return hits_.size();
  }
  size_t BoxCount(const PointF& lo, const PointF& hi) const {
    size_t n = 0;
    ForEachInBox(Key(lo.x, lo.y, lo.z), Key(hi.x, hi.y, hi.z),
                 [&](const openvdb::Coord&, float) { ++n; });
    return n;
  }
  double VisitAll() const {
    double sum = 0;
    for (auto it = grid_->cbeginValueOn(); it; ++it) sum += *it;
    return sum;
  }
  size_t HeightMap() const {
    const openvdb::CoordBBox b = grid_->evalActiveVoxelBoundingBox();
    const size_t w = b.dim().x(), h = b.dim().y();
    std::vector<float> heights(w * h, std::nanf(""));
    for (auto it = grid_->cbeginValueOn(); it; ++it) {
      const openvdb::Coord k = it.getCoord();
      float& top = heights[size_t(k.y() - b.min().y()) * w + size_t(k.x() - b.min().x())];
      const float z = static_cast<float>((k.z() + 0.5) * res_);
      if (std::isnan(top) || z > top) top = z;
    }
    size_t known = 0;
    for (float v : heights) known += !std::isnan(v);
    return known;
  }
  size_t OccupancyGrid() const {
    const openvdb::CoordBBox b = grid_->evalActiveVoxelBoundingBox();
    const size_t w = b.dim().x(), h = b.dim().y();
    std::vector<int8_t> cells(w * h, -1);
    for (auto it = grid_->cbeginValueOn(); it; ++it) {
      const openvdb::Coord k = it.getCoord();
      const double z = (k.z() + 0.5) * res_;
      if (z < -0.3 || z > 1.5) continue;
      int8_t& c = cells[size_t(k.y() - b.min().y()) * w + size_t(k.x() - b.min().x())];
      c = std::max<int8_t>(c, z >= 0.05 ? 100 : 0);
    }
    size_t occupied = 0;
    for (int8_t c : cells) occupied += c == 100;
    return occupied;
  }
  size_t Voxels() const { return grid_->activeVoxelCount(); }
  size_t LibBytes() const { return grid_->memUsage(); }
  void ReleaseScratch() { hits_ = {}; }

 private:
  using Leaf = openvdb::FloatTree::LeafNodeType;
  static void Init() {
    static const bool once = (openvdb::initialize(), true);
    (void)once;
  }
  openvdb::Coord Key(double x, double y, double z) const {
    return openvdb::Coord(static_cast<int>(std::floor(x * inv_)),
                          static_cast<int>(std::floor(y * inv_)),
                          static_cast<int>(std::floor(z * inv_)));
  }
  // fn(coord, value) for every active voxel with lo <= coord <= hi, leaf by leaf.
  template <class Fn>
  void ForEachInBox(const openvdb::Coord& lo, const openvdb::Coord& hi, Fn&& fn) const {
    const openvdb::CoordBBox box(lo, hi);
    auto acc = grid_->getConstAccessor();
    constexpr int kMask = ~(int(Leaf::DIM) - 1);
    for (int x = lo.x() & kMask; x <= hi.x(); x += Leaf::DIM) {
      for (int y = lo.y() & kMask; y <= hi.y(); y += Leaf::DIM) {
        for (int z = lo.z() & kMask; z <= hi.z(); z += Leaf::DIM) {
          const Leaf* leaf = acc.probeConstLeaf(openvdb::Coord(x, y, z));
          if (leaf == nullptr) continue;
          for (auto it = leaf->cbeginValueOn(); it; ++it) {
            if (box.isInside(it.getCoord())) fn(it.getCoord(), *it);
          }
        }
      }
    }
  }
  openvdb::FloatGrid::Ptr grid_;
  openvdb::FloatGrid::Accessor acc_;
  double res_, inv_;
  mutable std::vector<std::pair<openvdb::Coord, float>> hits_;  // reused result buffer
};

const bool openvdb_registered = [] {
  RegisterInserts<OpenVdbAdapter>("OpenVdb");
  RegisterMergedInserts<OpenVdbAdapter>("OpenVdb");
  RegisterRadius<OpenVdbAdapter>("OpenVdb");
  RegisterMapQueries<OpenVdbAdapter>("OpenVdb");
  RegisterMemory<OpenVdbAdapter>("OpenVdb");
  return true;
}();

}  // namespace
}  // namespace skimap::bench
