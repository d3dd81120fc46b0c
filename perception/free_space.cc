#include "perception/free_space.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <vector>

namespace skimap::perception {
namespace {

// A ray's part inside the slab, projected onto the xy plane, as column keys.
struct Segment {
  double ax, ay, bx, by;  // world metres
  int32_t kx0, ky0, kx1, ky1;
};

// Calls mark(kx, ky) for every column the segment crosses, a's first and b's last
// (Amanatides & Woo in 2D).
template <class Mark>
void WalkColumns(const Grid& grid, const Segment& s, Mark&& mark) {
  const double res = grid.resolution();
  const double origin[2] = {grid.origin().x, grid.origin().y};
  const double a[2] = {s.ax, s.ay}, dir[2] = {s.bx - s.ax, s.by - s.ay};
  int32_t k[2] = {s.kx0, s.ky0};
  const int32_t k_end[2] = {s.kx1, s.ky1};
  int step[2];
  double t_max[2], t_delta[2];
  for (int axis = 0; axis < 2; ++axis) {
    step[axis] = k_end[axis] > k[axis] ? 1 : k_end[axis] < k[axis] ? -1 : 0;
    if (step[axis] == 0 || dir[axis] == 0) {
      t_max[axis] = t_delta[axis] = std::numeric_limits<double>::infinity();
      continue;
    }
    const double boundary = origin[axis] + (k[axis] + (step[axis] > 0)) * res;
    t_max[axis] = (boundary - a[axis]) / dir[axis];
    t_delta[axis] = res / std::abs(dir[axis]);
  }
  mark(k[0], k[1]);
  int remaining = std::abs(k_end[0] - k[0]) + std::abs(k_end[1] - k[1]);
  while (remaining-- > 0) {
    // The nearer boundary among the axes that still have columns to cross.
    const int axis = k[0] == k_end[0] ? 1 : k[1] == k_end[1] ? 0 : t_max[1] < t_max[0] ? 1 : 0;
    k[axis] += step[axis];
    t_max[axis] += t_delta[axis];
    mark(k[0], k[1]);
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
  // Pass 1: the rays' slab segments and the key box they span.
  std::vector<Segment> segments;
  int32_t min_x = std::numeric_limits<int32_t>::max(), min_y = min_x;
  int32_t max_x = std::numeric_limits<int32_t>::min(), max_y = max_x;
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
      const Eigen::Vector3d a = o + t0 * (end - o), b = o + t1 * (end - o);
      Segment s{a.x(), a.y(), b.x(), b.y(), 0, 0, 0, 0};
      if (!grid.AxisToKey(s.ax, grid.origin().x, &s.kx0) ||
          !grid.AxisToKey(s.ay, grid.origin().y, &s.ky0) ||
          !grid.AxisToKey(s.bx, grid.origin().x, &s.kx1) ||
          !grid.AxisToKey(s.by, grid.origin().y, &s.ky1)) {
        continue;  // leaves the key range
      }
      min_x = std::min({min_x, s.kx0, s.kx1}), max_x = std::max({max_x, s.kx0, s.kx1});
      min_y = std::min({min_y, s.ky0, s.ky1}), max_y = std::max({max_y, s.ky0, s.ky1});
      segments.push_back(s);
    }
  }
  stats.rays = segments.size();
  if (segments.empty()) return stats;
  // Pass 2: the columns crossed, once per frame, in a bitmap over the key box.
  const size_t width = size_t(int64_t{max_x} - min_x + 1),
               height = size_t(int64_t{max_y} - min_y + 1);
  std::vector<uint64_t> bits((width * height + 63) / 64, 0);
  for (const Segment& s : segments) {
    WalkColumns(grid, s, [&](int32_t kx, int32_t ky) {
      const size_t i = size_t(ky - min_y) * width + size_t(kx - min_x);
      bits[i / 64] |= uint64_t{1} << (i % 64);
    });
  }
  std::vector<VoxelKey> keys;
  for (size_t w = 0; w < bits.size(); ++w) {
    for (uint64_t word = bits[w]; word != 0; word &= word - 1) {
      const size_t i = w * 64 + size_t(std::countr_zero(word));
      keys.push_back({min_x + int32_t(i % width), min_y + int32_t(i / width), 0});
    }
  }
  stats.columns = keys.size();
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
