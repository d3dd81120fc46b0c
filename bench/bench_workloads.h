// The query workloads of the side-by-side benchmarks and the reference answers every
// structure must reproduce (the harness fails a benchmark whose structure disagrees).
//
//   const Cloud& q = QueryCentersFor(Workload::kSurface);   // 1 024 voxel corners on the data
//   const std::vector<uint32_t>& want = ExactRadiusHits(Workload::kSurface, 20);  // per query
//   const VoxelBatch<WeightVoxel>& b = MergedBatch(RoomFrame(), 10);  // (key, weight) per voxel
//
// Radius queries are centred on voxel corners (a data point's voxel, lower corner). With
// radii that are whole multiples of the resolution, 4 d^2 / res^2 of every voxel centre is
// an odd-square sum (3 mod 8) and 4 r^2 / res^2 a multiple of 4: no centre lies within
// res^2 / 4 of the sphere in d^2, far above float rounding (~1e-5 res^2 here). So float and
// double implementations (PCL, nanoflann, OctoMap, SkiMap, OpenVDB) must return exactly the
// same hits, and ExactRadiusHits computes them in integer arithmetic.
//
// Thread safety: function-local caches; call from the benchmark thread only.
#ifndef SKIMAP_BENCH_BENCH_WORKLOADS_H_
#define SKIMAP_BENCH_BENCH_WORKLOADS_H_

#include <cstdint>
#include <vector>

#include "bench/bench_data.h"
#include "skimap/grid.h"
#include "skimap/voxel.h"
#include "skimap/voxel_batch.h"

namespace skimap::bench {

// The query workloads and their fixed resolutions.
enum class Workload { kUniform, kSurface, kBig };
inline constexpr int kUniformResMm = 10;  // 1 M uniform points, 1 cm voxels
inline constexpr int kSurfaceResMm = 10;  // room sweep surface map, 1 cm (active sphere)
inline constexpr int kBigResMm = 10;      // >= 10 M voxel warehouse map
inline constexpr size_t kQueryCount = 1024;

// Distinct voxel centres of a workload's points at `res_mm` (kUniform, kSurface): what a
// point index (kd-tree, PCL octree) stores to answer the same queries as a voxel map.
const Cloud& VoxelCenters(Workload w, int res_mm);
// Query points (fixed seeds): voxel corners for kUniform / kSurface (see above), data
// points for kBig (box queries).
const Cloud& QueryCentersFor(Workload w);
// The clouds a map is built from for a workload (frames, or one big cloud).
std::vector<const Cloud*> WorkloadClouds(Workload w);
const char* WorkloadName(Workload w);
// {RoomFrame()}: the room frame as a one-frame sequence.
const std::vector<Cloud>& RoomFrameList();

// For each query of QueryCentersFor(w) (kUniform or kSurface), the number of voxels of the
// workload whose centre lies within radius_cm of it, computed exactly with integers.
// REQUIRES: radius_cm * 10 is a multiple of the workload's resolution in mm.
const std::vector<uint32_t>& ExactRadiusHits(Workload w, int radius_cm);

// `cloud` merged per voxel at res_mm (one point = weight 1), finalized: the batch SkiMap
// integrates, and the same (key, weight) list the peers' merged rows are fed. Cached per
// (cloud address, res_mm).
const VoxelBatch<WeightVoxel>& MergedBatch(const Cloud& cloud, int res_mm);
// Sorted distinct keys of the union of `frames` at res_mm. Cached per (address, res_mm).
const std::vector<VoxelKey>& UnionKeys(const std::vector<Cloud>& frames, int res_mm);

}  // namespace skimap::bench

#endif  // SKIMAP_BENCH_BENCH_WORKLOADS_H_
