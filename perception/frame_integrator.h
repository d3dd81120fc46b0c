// Back-projection of RGB-D frames into voxel batches for the RGB volume.
//
//   VoxelBatch<RGBWeightedVoxel> batch;
//   IntegrationStats stats = BuildFrameBatch(frame, map.grid(), options, &batch);
//   map.Integrate(batch);      // fuse;  map.Deintegrate(batch) undoes it exactly
//
// Every depth pixel d != 0 (on the pixel_stride lattice) that is not a flying pixel (no
// 4-neighbour with depth differs from d by more than depth_edge_jump * d) with metric depth
// z = d * scale in [min_depth, max_depth] becomes the point z * ((u - cx) / fx, (v - cy) / fy, 1)
// in the camera frame, moved to the world by the pose, and contributes RGBWeightedVoxel(r, g, b, 1)
// (grey 128 without colour). BuildFrameBatch is deterministic, so building the same frame
// twice gives the same batch: that is what makes de-integration exact.
//
// Thread safety: free functions; the batch is the caller's.
#ifndef PERCEPTION_FRAME_INTEGRATOR_H_
#define PERCEPTION_FRAME_INTEGRATOR_H_

#include <cstddef>

#include "absl/status/status.h"
#include "base/thread_pool.h"
#include "perception/rgbd_frame.h"
#include "skimap/grid.h"
#include "skimap/voxel.h"
#include "skimap/voxel_batch.h"

namespace skimap::perception {

struct IntegrationOptions {
  double min_depth = 0.1;  // metres along the optical axis
  double max_depth = 5.0;
  int pixel_stride = 1;  // use every n-th pixel along rows and columns, >= 1
  // Flying pixels: a pixel whose depth differs from one of its 4 neighbours' (at full
  // resolution, with depth) by more than this fraction of its own is dropped; 0 keeps all.
  double depth_edge_jump = 0.05;
};

struct IntegrationStats {
  size_t points = 0;        // pixels fused
  size_t out_of_range = 0;  // valid depth outside [min_depth, max_depth]
  size_t no_key = 0;        // points outside the map's key range
  size_t depth_edges = 0;   // pixels dropped at depth discontinuities (depth_edge_jump)
};

// InvalidArgument naming the bad option ("min_depth", "max_depth", "pixel_stride",
// "depth_edge_jump").
absl::Status ValidateIntegrationOptions(const IntegrationOptions& options);

// Clears *batch and fills it with the frame's observations, finalized. With a pool,
// back-projection and sorting run on its threads too (VoxelBatch::AddPoints/Finalize);
// the batch is the same either way.
// REQUIRES: ValidateFrame(frame) and ValidateIntegrationOptions(options) are OK.
IntegrationStats BuildFrameBatch(const RgbdFrame& frame, const Grid& grid,
                                 const IntegrationOptions& options,
                                 VoxelBatch<RGBWeightedVoxel>* batch, ThreadPool* pool = nullptr);

}  // namespace skimap::perception

#endif  // PERCEPTION_FRAME_INTEGRATOR_H_
