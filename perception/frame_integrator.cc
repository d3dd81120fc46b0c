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
                                 VoxelBatch<RGBWeightedVoxel>* batch, ThreadPool* pool) {
  batch->Clear();
  IntegrationStats stats;
  const PinholeCamera& cam = frame.camera;
  const int stride = options.pixel_stride;
  const int cols = (cam.width + stride - 1) / stride, rows = (cam.height + stride - 1) / stride;
  const Eigen::Matrix3d rot = frame.pose.rotation.toRotationMatrix();
  const Eigen::Vector3d t = frame.pose.translation;
  // World direction of pixel (u, v) at unit depth = row_base[v] + col_term[u].
  std::vector<Eigen::Vector3d> col_term(cols), row_base(rows);
  for (int c = 0; c < cols; ++c) col_term[c] = rot.col(0) * ((c * stride - cam.cx) / cam.fx);
  for (int r = 0; r < rows; ++r) {
    row_base[r] = rot * Eigen::Vector3d(0, (r * stride - cam.cy) / cam.fy, 1);
  }
  const uint16_t* depth = frame.depth.pixels.data();
  const uint8_t* rgb = frame.color ? frame.color->rgb.data() : nullptr;
  const double scale = frame.depth_scale;
  const double min_depth = options.min_depth, max_depth = options.max_depth;
  size_t in_range = 0;
  for (int r = 0; r < rows; ++r) {
    const uint16_t* row = depth + size_t(r) * stride * cam.width;
    for (int c = 0; c < cols; ++c) {
      const uint16_t d = row[c * stride];
      if (d == 0) continue;
      const double z = d * scale;
      if (z >= min_depth && z <= max_depth) {
        ++in_range;
      } else {
        ++stats.out_of_range;
      }
    }
  }
  batch->AddPoints(
      grid, size_t(rows) * cols,
      [&](size_t i, Point3* p, RGBWeightedVoxel* obs) {
        const size_t r = i / cols, c = i % cols;
        const size_t pixel = r * stride * cam.width + c * stride;
        const uint16_t d = depth[pixel];
        const double z = d * scale;
        if (d == 0 || z < min_depth || z > max_depth) return false;
        const Eigen::Vector3d w = z * (row_base[r] + col_term[c]) + t;
        *p = {w.x(), w.y(), w.z()};
        *obs = rgb ? RGBWeightedVoxel(rgb[3 * pixel], rgb[3 * pixel + 1], rgb[3 * pixel + 2], 1.0f)
                   : RGBWeightedVoxel(128, 128, 128, 1.0f);
        return true;
      },
      pool);
  stats.no_key = batch->rejected();
  stats.points = in_range - stats.no_key;
  batch->Finalize(pool);
  return stats;
}

}  // namespace skimap::perception
