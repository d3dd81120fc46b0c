#include "bench/bench_harness.h"

#include "skimap/voxel_batch.h"

namespace skimap::bench {

const Cloud& SurfaceVoxelCenters(int res_mm) {
  static std::map<int, Cloud> cache;
  auto it = cache.find(res_mm);
  if (it != cache.end()) return it->second;
  const Grid grid(res_mm * 1e-3);
  VoxelBatch<WeightVoxel> batch;
  for (const Cloud& f : RoomSweep()) {
    for (const PointF& p : f) batch.Add(grid, p.x, p.y, p.z, WeightVoxel{1});
  }
  batch.Finalize();
  Cloud centers;
  centers.reserve(batch.size());
  for (const auto& item : batch.items()) {
    const Point3 c = grid.Center(item.key);
    centers.push_back({static_cast<float>(c.x), static_cast<float>(c.y), static_cast<float>(c.z)});
  }
  return cache.emplace(res_mm, std::move(centers)).first->second;
}

const Cloud& QueryCentersFor(Workload w) {
  switch (w) {
    case Workload::kUniform: {
      static const Cloud q = QueryCenters(UniformPoints(), kQueryCount, 7);
      return q;
    }
    case Workload::kSurface: {
      static const Cloud q = QueryCenters(SurfaceVoxelCenters(kSurfaceResMm), kQueryCount, 8);
      return q;
    }
    case Workload::kBig:
      break;
  }
  static const Cloud q = QueryCenters(BigMapPoints(), kQueryCount, 9);
  return q;
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
