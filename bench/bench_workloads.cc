#include "bench/bench_workloads.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <utility>

namespace skimap::bench {
namespace {

int WorkloadResMm(Workload w) {
  switch (w) {
    case Workload::kUniform:
      return kUniformResMm;
    case Workload::kSurface:
      return kSurfaceResMm;
    case Workload::kBig:
      break;
  }
  return kBigResMm;
}

// Radius query corners: the lower corner of the voxel of a point drawn from the data.
struct Corners {
  Cloud centers;               // world coordinates of the corners
  std::vector<VoxelKey> keys;  // corner = key * resolution
};

Corners MakeCorners(const Cloud& data, int res_mm, uint32_t seed) {
  const Grid grid(res_mm * 1e-3);
  Corners c;
  for (const PointF& p : QueryCenters(data, kQueryCount, seed)) {
    VoxelKey k;
    grid.ToKey(p.x, p.y, p.z, &k);
    c.keys.push_back(k);
    c.centers.push_back({static_cast<float>(k.x * grid.resolution()),
                         static_cast<float>(k.y * grid.resolution()),
                         static_cast<float>(k.z * grid.resolution())});
  }
  return c;
}

const Corners& CornersFor(Workload w) {
  if (w == Workload::kUniform) {
    static const Corners c = MakeCorners(UniformPoints(), kUniformResMm, 7);
    return c;
  }
  static const Corners c =
      MakeCorners(VoxelCenters(Workload::kSurface, kSurfaceResMm), kSurfaceResMm, 8);
  return c;
}

// Sorted packed keys of every voxel of a query workload.
const std::vector<uint64_t>& PackedKeys(Workload w) {
  static std::map<Workload, std::vector<uint64_t>> cache;
  auto it = cache.find(w);
  if (it != cache.end()) return it->second;
  const Grid grid(WorkloadResMm(w) * 1e-3);
  VoxelBatch<WeightVoxel> batch;
  for (const Cloud* c : WorkloadClouds(w)) {
    for (const PointF& p : *c) batch.Add(grid, p.x, p.y, p.z, WeightVoxel{1});
  }
  batch.Finalize();
  std::vector<uint64_t> keys;
  keys.reserve(batch.size());
  for (const auto& item : batch.items()) keys.push_back(PackKey(item.key));
  std::sort(keys.begin(), keys.end());
  return cache.emplace(w, std::move(keys)).first->second;
}

}  // namespace

const Cloud& VoxelCenters(Workload w, int res_mm) {
  static std::map<std::pair<Workload, int>, Cloud> cache;
  auto it = cache.find({w, res_mm});
  if (it != cache.end()) return it->second;
  const Grid grid(res_mm * 1e-3);
  VoxelBatch<WeightVoxel> batch;
  for (const Cloud* c : WorkloadClouds(w)) {
    for (const PointF& p : *c) batch.Add(grid, p.x, p.y, p.z, WeightVoxel{1});
  }
  batch.Finalize();
  Cloud centers;
  centers.reserve(batch.size());
  for (const auto& item : batch.items()) {
    const Point3 c = grid.Center(item.key);
    centers.push_back({static_cast<float>(c.x), static_cast<float>(c.y), static_cast<float>(c.z)});
  }
  return cache.emplace(std::pair{w, res_mm}, std::move(centers)).first->second;
}

const Cloud& QueryCentersFor(Workload w) {
  if (w != Workload::kBig) return CornersFor(w).centers;
  static const Cloud q = QueryCenters(BigMapPoints(), kQueryCount, 9);
  return q;
}

const std::vector<uint32_t>& ExactRadiusHits(Workload w, int radius_cm) {
  static std::map<std::pair<Workload, int>, std::vector<uint32_t>> cache;
  auto it = cache.find({w, radius_cm});
  if (it != cache.end()) return it->second;
  const int res_mm = WorkloadResMm(w);
  const int64_t r = radius_cm * 10 / res_mm;  // radius in voxels (whole, see REQUIRES)
  const std::vector<uint64_t>& keys = PackedKeys(w);
  std::vector<uint32_t> hits;
  // Voxel k is a hit when sum over axes of (2 (k - q) + 1)^2 < 4 r^2 (never equal).
  auto odd_sq = [](int64_t d) { return (2 * d + 1) * (2 * d + 1); };
  for (const VoxelKey& q : CornersFor(w).keys) {
    uint32_t n = 0;
    for (int64_t dx = -r; dx < r; ++dx) {
      const int64_t rem = 4 * r * r - odd_sq(dx);
      const int32_t x = static_cast<int32_t>(q.x + dx);
      // Every voxel of plane x with y in [q.y - r, q.y + r - 1]: contiguous in key order.
      auto lo = std::lower_bound(keys.begin(), keys.end(),
                                 PackKey({x, static_cast<int32_t>(q.y - r), kMinKey}));
      const uint64_t hi = PackKey({x, static_cast<int32_t>(q.y + r - 1), kMaxKey});
      for (; lo != keys.end() && *lo <= hi; ++lo) {
        const VoxelKey k = UnpackKey(*lo);
        n += odd_sq(k.y - q.y) + odd_sq(k.z - q.z) < rem;
      }
    }
    hits.push_back(n);
  }
  return cache.emplace(std::pair{w, radius_cm}, std::move(hits)).first->second;
}

const VoxelBatch<WeightVoxel>& MergedBatch(const Cloud& cloud, int res_mm) {
  static std::map<std::pair<const Cloud*, int>, std::unique_ptr<VoxelBatch<WeightVoxel>>> cache;
  auto& slot = cache[{&cloud, res_mm}];
  if (slot == nullptr) {
    const Grid grid(res_mm * 1e-3);
    slot = std::make_unique<VoxelBatch<WeightVoxel>>();
    slot->AddPoints(grid, cloud.size(), [&](size_t i, Point3* p, WeightVoxel* d) {
      *p = {cloud[i].x, cloud[i].y, cloud[i].z};
      *d = WeightVoxel{1};
      return true;
    });
    slot->Finalize();
  }
  return *slot;
}

const std::vector<VoxelKey>& UnionKeys(const std::vector<Cloud>& frames, int res_mm) {
  static std::map<std::pair<const void*, int>, std::vector<VoxelKey>> cache;
  auto it = cache.find({&frames, res_mm});
  if (it != cache.end()) return it->second;
  const Grid grid(res_mm * 1e-3);
  VoxelBatch<WeightVoxel> batch;
  for (const Cloud& f : frames) {
    for (const PointF& p : f) batch.Add(grid, p.x, p.y, p.z, WeightVoxel{1});
  }
  batch.Finalize();
  std::vector<VoxelKey> keys;
  keys.reserve(batch.size());
  for (const auto& item : batch.items()) keys.push_back(item.key);
  return cache.emplace(std::pair{&frames, res_mm}, std::move(keys)).first->second;
}

std::vector<const Cloud*> WorkloadClouds(Workload w) {
  switch (w) {
    case Workload::kUniform:
      return {&UniformPoints()};
    case Workload::kSurface: {
      std::vector<const Cloud*> out;
      for (const Cloud& f : RoomSweep()) out.push_back(&f);
      return out;
    }
    case Workload::kBig:
      break;
  }
  return {&BigMapPoints()};
}

const char* WorkloadName(Workload w) {
  switch (w) {
    case Workload::kUniform:
      return "Uniform";
    case Workload::kSurface:
      return "Surface";
    case Workload::kBig:
      break;
  }
  return "Big";
}

const std::vector<Cloud>& RoomFrameList() {
  static const std::vector<Cloud> frames{RoomFrame()};
  return frames;
}

}  // namespace skimap::bench
