// Free-space carving for the 2D occupancy grid: the (x, y) columns the depth rays swept
// inside the grid's z band, before they hit a surface, are free.
//
//   VoxelBatch<FreeColumnsVoxel> free;
//   BuildFreeSpaceBatch(frame, free_map.grid(), integration, {.min_z = 0.05, .max_z = 1.5},
//                       &free);
//   free_map.Integrate(free);      // free_map.Deintegrate(free) undoes it exactly
//
// For every pixel on the pixel_stride lattice whose depth is valid and inside the
// integration depth range, the segment from the camera centre to one voxel short of the
// hit is clipped to the world z slab [min_z, max_z]. Seen from above, that part is a radius
// interval [r0, r1] along the ray's azimuth from the camera's column. The frame's rays make
// a fan: azimuth bins one column wide at the farthest reach, each the union of its rays'
// intervals; a bin without rays between two bins with rays at most 2.5 lattice steps
// (2.5 * pixel_stride / f radians) apart gets the intersection of theirs, so the wedge
// between neighbouring rays is free up to the nearer hit, and a wider hole of missing depth
// carves nothing. Every column whose centre lies in the fan (and the camera's own column,
// when a ray starts there) gets a count of 1 in its 4 × 4 block's FreeColumnsVoxel
// (skimap/free_columns_voxel.h): the free volume is a single layer of blocks whose counts
// are the frames that saw through each column's band. Pixels without
// depth carve nothing (no return is no evidence). Deterministic, like BuildFrameBatch, so
// pose updates can subtract a frame's free evidence exactly. Cost: one pass over the rays
// and one over the fan's blocks; a block whose corners show it wholly inside or outside the
// fan is decided at once, the others column by column, with the same answer
// (bench/free_space_bench.cc).
//
// Thread safety: free functions; the batch is the caller's.
#ifndef PERCEPTION_FREE_SPACE_H_
#define PERCEPTION_FREE_SPACE_H_

#include <cstddef>

#include "absl/status/status.h"
#include "base/thread_pool.h"
#include "perception/frame_integrator.h"
#include "perception/rgbd_frame.h"
#include "skimap/free_columns_voxel.h"
#include "skimap/grid.h"
#include "skimap/voxel_batch.h"

namespace skimap::perception {

struct FreeSpaceOptions {
  int pixel_stride = 4;  // carve along every n-th pixel's ray in rows and columns, 1..64
  double min_z = 0.05;   // world z slab that is carved, metres (the grid's robot band)
  double max_z = 1.5;
};

struct FreeSpaceStats {
  size_t rays = 0;     // rays whose part reaches into the slab
  size_t columns = 0;  // columns in the frame's fan (and the camera's own, when a ray starts
                       // there), held by the batch's blocks
};

// InvalidArgument naming the bad option ("carve_pixel_stride", "band").
absl::Status ValidateFreeSpaceOptions(const FreeSpaceOptions& options);

// Clears *batch and fills it with the frame's free-space evidence, finalized. With a pool,
// a fan of at least 65 536 columns (its key box) has its blocks split over the pool's
// threads; the rays stay on the caller. The batch is the same either way.
// REQUIRES: ValidateFrame(frame), ValidateIntegrationOptions(integration) and
// ValidateFreeSpaceOptions(options) are OK.
FreeSpaceStats BuildFreeSpaceBatch(const RgbdFrame& frame, const Grid& grid,
                                   const IntegrationOptions& integration,
                                   const FreeSpaceOptions& options,
                                   VoxelBatch<FreeColumnsVoxel>* batch, ThreadPool* pool = nullptr);

}  // namespace skimap::perception

#endif  // PERCEPTION_FREE_SPACE_H_
