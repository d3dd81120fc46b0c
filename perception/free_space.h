// Free-space carving for the 2D occupancy grid: the (x, y) columns a depth ray crossed
// inside the grid's z band, before it hit a surface, are free.
//
//   VoxelBatch<WeightVoxel> free;
//   BuildFreeSpaceBatch(frame, free_map.grid(), integration, {.min_z = 0.05, .max_z = 1.5},
//                       &free);
//   free_map.Integrate(free);      // free_map.Deintegrate(free) undoes it exactly
//
// For every pixel on the pixel_stride lattice whose depth is valid and inside the
// integration depth range, the segment from the camera centre to one voxel short of the
// hit is clipped to the world z slab [min_z, max_z], projected onto the xy plane and walked
// cell by cell (2D DDA, Amanatides & Woo 1987). Each column crossed by at least one ray of
// the frame gets WeightVoxel(1) at z key 0: the free volume is a single layer whose weight
// counts the frames that saw through a column's band. Pixels without depth carve nothing
// (no return is no evidence). Deterministic, like BuildFrameBatch, so pose updates can
// subtract a frame's free evidence exactly.
//
// Thread safety: free functions; the batch is the caller's.
#ifndef PERCEPTION_FREE_SPACE_H_
#define PERCEPTION_FREE_SPACE_H_

#include <cstddef>

#include "absl/status/status.h"
#include "perception/frame_integrator.h"
#include "perception/rgbd_frame.h"
#include "skimap/grid.h"
#include "skimap/voxel.h"
#include "skimap/voxel_batch.h"

namespace skimap::perception {

struct FreeSpaceOptions {
  int pixel_stride = 4;  // carve along every n-th pixel's ray in rows and columns, 1..64
  double min_z = 0.05;   // world z slab that is carved, metres (the grid's robot band)
  double max_z = 1.5;
};

struct FreeSpaceStats {
  size_t rays = 0;     // rays walked (they reached into the slab)
  size_t columns = 0;  // distinct columns the frame's rays crossed
};

// InvalidArgument naming the bad option ("carve_pixel_stride", "band").
absl::Status ValidateFreeSpaceOptions(const FreeSpaceOptions& options);

// Clears *batch and fills it with the frame's free-space evidence, finalized.
// REQUIRES: ValidateFrame(frame), ValidateIntegrationOptions(integration) and
// ValidateFreeSpaceOptions(options) are OK.
FreeSpaceStats BuildFreeSpaceBatch(const RgbdFrame& frame, const Grid& grid,
                                   const IntegrationOptions& integration,
                                   const FreeSpaceOptions& options, VoxelBatch<WeightVoxel>* batch);

}  // namespace skimap::perception

#endif  // PERCEPTION_FREE_SPACE_H_
