#include "perception/free_space.h"

#include <cmath>
#include <cstdlib>
#include <limits>
#include <vector>

namespace skimap::perception {
namespace {

// Appends the keys of the voxels the segment a -> b crosses, a's voxel first and b's last
// (Amanatides & Woo). Nothing when either end has no key.
void WalkSegment(const Grid& grid, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                 std::vector<VoxelKey>* keys) {
  VoxelKey start, end;
  if (!grid.ToKey(a.x(), a.y(), a.z(), &start) || !grid.ToKey(b.x(), b.y(), b.z(), &end)) return;
  const double res = grid.resolution();
  const double origin[3] = {grid.origin().x, grid.origin().y, grid.origin().z};
  int32_t k[3] = {start.x, start.y, start.z};
  const int32_t k_end[3] = {end.x, end.y, end.z};
  const Eigen::Vector3d dir = b - a;
  int step[3];
  double t_max[3], t_delta[3];
  for (int axis = 0; axis < 3; ++axis) {
    constexpr double kInf = std::numeric_limits<double>::infinity();
    step[axis] = k_end[axis] > k[axis] ? 1 : k_end[axis] < k[axis] ? -1 : 0;
    if (step[axis] == 0 || dir[axis] == 0) {
      t_max[axis] = t_delta[axis] = kInf;
      continue;
    }
    const double boundary = origin[axis] + (k[axis] + (step[axis] > 0)) * res;
    t_max[axis] = (boundary - a[axis]) / dir[axis];
    t_delta[axis] = res / std::abs(dir[axis]);
  }
  keys->push_back(start);
  int remaining = std::abs(k_end[0] - k[0]) + std::abs(k_end[1] - k[1]) + std::abs(k_end[2] - k[2]);
  while (remaining-- > 0) {
    // The nearest boundary among the axes that still have voxels to cross.
    int axis = -1;
    for (int i = 0; i < 3; ++i) {
      if (k[i] != k_end[i] && (axis < 0 || t_max[i] < t_max[axis])) axis = i;
    }
    k[axis] += step[axis];
    t_max[axis] += t_delta[axis];
    keys->push_back({k[0], k[1], k[2]});
  }
}

}  // namespace

absl::Status ValidateFreeSpaceOptions(const FreeSpaceOptions& o) {
  if (o.pixel_stride < 1 || o.pixel_stride > 64) {
    return absl::InvalidArgumentError("carve_pixel_stride must be in 1..64");
  }
  if (!std::isfinite(o.min_z) || !std::isfinite(o.max_z) || !(o.min_z <= o.max_z)) {
    return absl::InvalidArgumentError("band: carving needs finite min_z <= max_z");
  }
  return absl::OkStatus();
}

FreeSpaceStats BuildFreeSpaceBatch(const RgbdFrame& frame, const Grid& grid,
                                   const IntegrationOptions& integration,
                                   const FreeSpaceOptions& options,
                                   VoxelBatch<WeightVoxel>* batch) {
  batch->Clear();
  FreeSpaceStats stats;
  const PinholeCamera& cam = frame.camera;
  const int stride = options.pixel_stride;
  const Eigen::Matrix3d rot = frame.pose.rotation.toRotationMatrix();
  const Eigen::Vector3d& o = frame.pose.translation;
  const double res = grid.resolution();
  const uint16_t* depth = frame.depth.pixels.data();
  std::vector<VoxelKey> keys;
  for (int v = 0; v < cam.height; v += stride) {
    for (int u = 0; u < cam.width; u += stride) {
      const uint16_t d = depth[size_t(v) * cam.width + u];
      if (d == 0) continue;
      const double z = d * frame.depth_scale;
      if (z < integration.min_depth || z > integration.max_depth) continue;
      const Eigen::Vector3d ray =
          rot * Eigen::Vector3d((u - cam.cx) / cam.fx, (v - cam.cy) / cam.fy, 1);
      const double length = z * ray.norm();
      if (length <= res) continue;
      // From the camera to one voxel short of the hit, clipped to the slab.
      const Eigen::Vector3d end = o + ray * (z * (length - res) / length);
      const double dz = end.z() - o.z();
      double t0 = 0, t1 = 1;
      if (std::abs(dz) < 1e-12) {
        if (o.z() < options.min_z || o.z() > options.max_z) continue;
      } else {
        double ta = (options.min_z - o.z()) / dz, tb = (options.max_z - o.z()) / dz;
        if (ta > tb) std::swap(ta, tb);
        t0 = std::max(t0, ta);
        t1 = std::min(t1, tb);
        if (!(t0 < t1)) continue;
      }
      const size_t before = keys.size();
      WalkSegment(grid, o + t0 * (end - o), o + t1 * (end - o), &keys);
      stats.rays += keys.size() > before;
    }
  }
  stats.voxel_crossings = keys.size();
  // Keys are integers: a unit grid at the origin maps them onto themselves.
  batch->AddPoints(Grid(1.0), keys.size(), [&](size_t i, Point3* p, WeightVoxel* w) {
    *p = {double(keys[i].x), double(keys[i].y), double(keys[i].z)};
    w->weight = 1;
    return true;
  });
  batch->Finalize();
  return stats;
}

}  // namespace skimap::perception
