#include "perception/frame_integrator.h"

#include <cmath>
#include <vector>

namespace skimap::perception {

absl::Status ValidateIntegrationOptions(const IntegrationOptions& o) {
  if (!(o.min_depth >= 0) || !std::isfinite(o.min_depth)) {
    return absl::InvalidArgumentError("min_depth must be finite and >= 0");
  }
  if (!(o.max_depth > o.min_depth) || !std::isfinite(o.max_depth)) {
    return absl::InvalidArgumentError("max_depth must be finite and > min_depth");
  }
  if (o.pixel_stride < 1 || o.pixel_stride > 64) {
    return absl::InvalidArgumentError("pixel_stride must be in 1..64");
  }
  return absl::OkStatus();
}

IntegrationStats BuildFrameBatch(const RgbdFrame& frame, const Grid& grid,
                                 const IntegrationOptions& options,
                                 VoxelBatch<RGBWeightedVoxel>* batch) {
  batch->Clear();
  IntegrationStats stats;
  const PinholeCamera& cam = frame.camera;
  const int stride = options.pixel_stride;
  batch->Reserve(size_t(cam.width / stride + 1) * size_t(cam.height / stride + 1));
  const Eigen::Matrix3d rot = frame.pose.rotation.toRotationMatrix();
  const Eigen::Vector3d& t = frame.pose.translation;
  // Per-column ray directions (x) are shared by every row.
  std::vector<double> ray_x(cam.width);
  for (int u = 0; u < cam.width; ++u) ray_x[u] = (u - cam.cx) / cam.fx;
  const uint16_t* depth = frame.depth.pixels.data();
  const uint8_t* rgb = frame.color ? frame.color->rgb.data() : nullptr;
  for (int v = 0; v < cam.height; v += stride) {
    const double ray_y = (v - cam.cy) / cam.fy;
    // World position of the row's rays at unit depth, minus the column term.
    const Eigen::Vector3d row_base = rot * Eigen::Vector3d(0, ray_y, 1);
    for (int u = 0; u < cam.width; u += stride) {
      const size_t i = size_t(v) * cam.width + u;
      if (depth[i] == 0) continue;
      const double z = depth[i] * frame.depth_scale;
      if (z < options.min_depth || z > options.max_depth) {
        ++stats.out_of_range;
        continue;
      }
      const Eigen::Vector3d p = z * (row_base + rot.col(0) * ray_x[u]) + t;
      const RGBWeightedVoxel obs =
          rgb ? RGBWeightedVoxel(rgb[3 * i], rgb[3 * i + 1], rgb[3 * i + 2], 1.0f)
              : RGBWeightedVoxel(128, 128, 128, 1.0f);
      if (batch->Add(grid, p.x(), p.y(), p.z(), obs)) {
        ++stats.points;
      } else {
        ++stats.no_key;
      }
    }
  }
  batch->Finalize();
  return stats;
}

}  // namespace skimap::perception
