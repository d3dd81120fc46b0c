// One depth-image row back-projected into voxel keys: the inner loop of BuildFrameBatch
// (perception/frame_integrator.h).
//
//   RowProjection p{...};                       // the row's pixels, rays, pose and grid
//   RowCounts n = ProjectRow(p, keys_x, keys_y, keys_z, state);
//
// Pixel c with depth d = depth[c] (d != 0) and z = d * scale in [min_depth, max_depth] is
// the world point z * (base + ray[c]) + t; its key per axis is Grid::AxisToKey of that
// coordinate: floor((v - origin) * inv_resolution), computed with the same double
// operations in the same order, so the keys are bit for bit Grid::ToKey's. state[c] is
// kRowUse (a key), kRowNoKey (valid depth in range, coordinate outside the key range or not
// finite) or kRowSkip (no depth or out of range); keys of a pixel that is not kRowUse are 0.
//
// ProjectRow runs 4 pixels per step with AVX2 on CPUs that have it (checked at run time)
// and ProjectRowScalar otherwise; both give exactly the same output.
//
// Thread safety: pure functions.
#ifndef PERCEPTION_ROW_PROJECTION_H_
#define PERCEPTION_ROW_PROJECTION_H_

#include <cstdint>

namespace skimap::perception {

// Values of state[c] (VoxelBatch::RowState's).
inline constexpr uint8_t kRowSkip = 0, kRowUse = 1, kRowNoKey = 2;

struct RowProjection {
  const uint16_t* depth;  // the row's `cols` pixels, contiguous
  int cols;
  double scale, min_depth, max_depth;
  const double* ray_x;  // per column: the rotated (u - cx) / fx term, per axis
  const double* ray_y;
  const double* ray_z;
  double base_x, base_y, base_z;  // the row's rotated ((v - cy) / fy, 1) term
  double tx, ty, tz;              // the camera position
  double ox, oy, oz;              // the grid's origin
  double inv_resolution;
};

struct RowCounts {
  uint32_t in_range = 0;      // valid depth inside [min_depth, max_depth]
  uint32_t out_of_range = 0;  // valid depth outside it
};

RowCounts ProjectRow(const RowProjection& p, int32_t* keys_x, int32_t* keys_y, int32_t* keys_z,
                     uint8_t* state);
// The one-pixel-at-a-time reference (and the path without AVX2).
RowCounts ProjectRowScalar(const RowProjection& p, int32_t* keys_x, int32_t* keys_y,
                           int32_t* keys_z, uint8_t* state);

}  // namespace skimap::perception

#endif  // PERCEPTION_ROW_PROJECTION_H_
