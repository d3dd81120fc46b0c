#include "server/core/recognition/instance_checks.h"

#include <algorithm>
#include <cmath>
#include <optional>

namespace skimap::server {
namespace {

constexpr float kColourTolerance = 40;    // mean absolute difference per channel
constexpr float kViewTolerance = 0.015f;  // metres
constexpr float kViewSlack = 0.01f;       // metres
constexpr double kNearestView = 0.01;     // metres: bounds the projection (pixels fit a long)
constexpr size_t kViewPoints = 100;       // surface points a view checks, about
// A point whose surface the view ray grazes (|cos| of the angle between them under this,
// more than 70 degrees) counts for neither: there a pose a millimetre off, or the trained
// voxels' centimetre, puts the point beside the silhouette, in front of the background.
constexpr float kMinViewCosine = 0.35f;

}  // namespace

SurfaceFit FitSurface(const Volume& rgb, const recognition::ObjectShape& shape,
                      const Eigen::Isometry3f& pose) {
  SurfaceFit fit;
  if (shape.surface.empty()) return fit;
  int observed = 0, agree = 0;
  for (const recognition::SurfacePoint& s : shape.surface) {
    const Eigen::Vector3f w = pose * s.p;
    VoxelKey key;
    if (!rgb.grid().ToKey(w.x(), w.y(), w.z(), &key)) continue;
    std::optional<RGBWeightedVoxel> v = rgb.Find(key);
    if (!v.has_value()) continue;
    ++observed;
    const Eigen::Vector3f c(v->Red(), v->Green(), v->Blue());
    if ((c - s.rgb).cwiseAbs().mean() < kColourTolerance) ++agree;
  }
  fit.observed = static_cast<float>(observed) / shape.surface.size();
  fit.colour = observed > 0 ? static_cast<float>(agree) / observed : 0;
  return fit;
}

void CountView(const recognition::ObjectShape& shape, const Eigen::Isometry3f& pose,
               const ViewFrame& view, uint32_t* agree, uint32_t* conflict) {
  const perception::PinholeCamera& cam = view.camera;
  const perception::DepthImage& depth = *view.depth;
  const Eigen::Isometry3f to_camera = view.camera_from_world * pose;
  const float nearest = static_cast<float>(std::max(view.min_depth, kNearestView));
  // A bounding sphere wholly behind the sensor's range or beside the image: nothing to count
  // (most of a map's keyframes do not look at a given instance).
  const Eigen::Vector3f c = to_camera * shape.centre;
  const float reach = shape.radius + kViewSlack;
  if (c.z() + reach < nearest) return;
  if (c.z() - reach > nearest) {
    const float near_z = c.z() - reach;
    const float u = static_cast<float>(cam.fx) * c.x() / c.z() + static_cast<float>(cam.cx);
    const float v = static_cast<float>(cam.fy) * c.y() / c.z() + static_cast<float>(cam.cy);
    // |u(c + d) - u(c)| <= fx |d| (1 + |x / z|) / (z - |d|) for |d| <= reach.
    const float ru =
        static_cast<float>(cam.fx) * reach * (1 + std::abs(c.x() / c.z())) / near_z + 1;
    const float rv =
        static_cast<float>(cam.fy) * reach * (1 + std::abs(c.y() / c.z())) / near_z + 1;
    if (u + ru < 0 || v + rv < 0 || u - ru > depth.width || v - rv > depth.height) return;
  }
  const size_t stride = std::max<size_t>(1, shape.surface.size() / kViewPoints);
  for (size_t i = 0; i < shape.surface.size(); i += stride) {
    const Eigen::Vector3f p = to_camera * shape.surface[i].p;
    if (!(p.z() >= nearest)) continue;
    const Eigen::Vector3f n = to_camera.linear() * shape.surface[i].normal;
    if (!n.isZero() && std::abs(n.dot(p)) < kMinViewCosine * p.norm()) continue;
    const long u = std::lround(cam.fx * p.x() / p.z() + cam.cx);
    const long v = std::lround(cam.fy * p.y() / p.z() + cam.cy);
    const long r = std::max(1L, std::lround(cam.fx * kViewSlack / p.z()));
    int measured = 0, behind = 0;
    bool agrees = false;
    for (long dv = -r; dv <= r; dv += r) {
      for (long du = -r; du <= r; du += r) {
        const long x = u + du, y = v + dv;
        if (x < 0 || y < 0 || x >= depth.width || y >= depth.height) continue;
        const uint16_t raw = depth.pixels[static_cast<size_t>(y) * depth.width + x];
        if (raw == 0) continue;
        ++measured;
        const float z = static_cast<float>(raw * view.depth_scale);
        agrees |= std::abs(p.z() - z) <= kViewTolerance;
        behind += z > p.z() + kViewTolerance;
      }
    }
    if (agrees) {
      ++*agree;
    } else if (measured >= 5 && behind == measured) {
      ++*conflict;
    }
  }
}

bool Overlap(const recognition::ObjectShape& a, const Eigen::Isometry3f& pose_a,
             const recognition::ObjectShape& b, const Eigen::Isometry3f& pose_b) {
  if (a.surface.empty() ||
      ((pose_a * a.centre) - (pose_b * b.centre)).norm() > a.radius + b.radius) {
    return false;
  }
  const Eigen::Isometry3f into_b = pose_b.inverse() * pose_a;
  const Eigen::Vector3f half = (b.half_extent.array() - 0.005f).max(0.0f).matrix();
  size_t inside = 0;
  for (const recognition::SurfacePoint& s : a.surface) {
    const Eigen::Vector3f p = into_b * s.p - b.centre;
    inside += (p.cwiseAbs().array() <= half.array()).all();
  }
  return inside * 5 > a.surface.size();
}

}  // namespace skimap::server
