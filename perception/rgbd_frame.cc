#include "perception/rgbd_frame.h"

#include <cmath>

#include "absl/strings/str_cat.h"

namespace skimap::perception {
namespace {

constexpr int kMaxIntrinsicsSide = 8192;

bool Finite(double v) { return std::isfinite(v); }

}  // namespace

absl::Status ValidateCamera(const PinholeCamera& c) {
  if (!(c.fx > 0) || !Finite(c.fx)) {
    return absl::InvalidArgumentError("intrinsics.fx must be finite and > 0");
  }
  if (!(c.fy > 0) || !Finite(c.fy)) {
    return absl::InvalidArgumentError("intrinsics.fy must be finite and > 0");
  }
  if (!Finite(c.cx)) return absl::InvalidArgumentError("intrinsics.cx must be finite");
  if (!Finite(c.cy)) return absl::InvalidArgumentError("intrinsics.cy must be finite");
  if (c.width <= 0 || c.width > kMaxIntrinsicsSide) {
    return absl::InvalidArgumentError(
        absl::StrCat("intrinsics.width must be in 1..", kMaxIntrinsicsSide));
  }
  if (c.height <= 0 || c.height > kMaxIntrinsicsSide) {
    return absl::InvalidArgumentError(
        absl::StrCat("intrinsics.height must be in 1..", kMaxIntrinsicsSide));
  }
  // Plausibility (docs/api.md, "Frame limits"): a field of view a real camera can have and
  // a principal point near the image; anything else puts the points far from the camera.
  const auto fov = [](double side, double f) { return 2 * std::atan(side / (2 * f)) * 180 / M_PI; };
  if (const double a = fov(c.width, c.fx); !(a >= kMinFovDegrees && a <= kMaxFovDegrees)) {
    return absl::InvalidArgumentError(
        absl::StrCat("intrinsics.fx: horizontal field of view 2*atan(width/(2*fx)) = ", a,
                     " degrees, outside ", kMinFovDegrees, "..", kMaxFovDegrees));
  }
  if (const double a = fov(c.height, c.fy); !(a >= kMinFovDegrees && a <= kMaxFovDegrees)) {
    return absl::InvalidArgumentError(
        absl::StrCat("intrinsics.fy: vertical field of view 2*atan(height/(2*fy)) = ", a,
                     " degrees, outside ", kMinFovDegrees, "..", kMaxFovDegrees));
  }
  if (!(c.cx >= -0.5 * c.width && c.cx <= 1.5 * c.width)) {
    return absl::InvalidArgumentError(absl::StrCat("intrinsics.cx: ", c.cx, " is outside ",
                                                   -0.5 * c.width, "..", 1.5 * c.width,
                                                   " (the image widened by half its width)"));
  }
  if (!(c.cy >= -0.5 * c.height && c.cy <= 1.5 * c.height)) {
    return absl::InvalidArgumentError(absl::StrCat("intrinsics.cy: ", c.cy, " is outside ",
                                                   -0.5 * c.height, "..", 1.5 * c.height,
                                                   " (the image widened by half its height)"));
  }
  return absl::OkStatus();
}

absl::Status ValidatePose(const CameraPose& pose) {
  const Eigen::Vector4d q = pose.rotation.coeffs();
  if (!q.allFinite()) return absl::InvalidArgumentError("pose.rotation must be finite");
  if (std::abs(q.norm() - 1.0) > kQuaternionNormTolerance) {
    return absl::InvalidArgumentError(
        absl::StrCat("pose.rotation is not a unit quaternion (norm ", q.norm(), ")"));
  }
  if (!pose.translation.allFinite()) {
    return absl::InvalidArgumentError("pose.translation must be finite");
  }
  return absl::OkStatus();
}

absl::Status ValidateFrame(const RgbdFrame& f) {
  if (absl::Status s = ValidateCamera(f.camera); !s.ok()) return s;
  if (absl::Status s = ValidatePose(f.pose); !s.ok()) return s;
  if (!(f.depth_scale > 0) || !Finite(f.depth_scale)) {
    return absl::InvalidArgumentError("depth_scale must be finite and > 0");
  }
  if (f.depth.width != f.camera.width || f.depth.height != f.camera.height ||
      f.depth.pixels.size() != size_t(f.depth.width) * f.depth.height) {
    return absl::InvalidArgumentError("depth: image size differs from intrinsics");
  }
  if (f.color && (f.color->width != f.camera.width || f.color->height != f.camera.height ||
                  f.color->rgb.size() != size_t(f.color->width) * f.color->height * 3)) {
    return absl::InvalidArgumentError("color: image size differs from intrinsics");
  }
  return absl::OkStatus();
}

Eigen::Isometry3d ToIsometry(const CameraPose& pose) {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = pose.rotation.toRotationMatrix();
  t.translation() = pose.translation;
  return t;
}

void HalfResolution(const DepthImage& depth, const PinholeCamera& camera, DepthImage* half,
                    PinholeCamera* half_camera) {
  // u_full / 2 = (fx / 2) X / Z + cx / 2: half pixel x is full pixel 2x.
  *half_camera = {.fx = camera.fx / 2,
                  .fy = camera.fy / 2,
                  .cx = camera.cx / 2,
                  .cy = camera.cy / 2,
                  .width = depth.width / 2,
                  .height = depth.height / 2};
  half->width = half_camera->width;
  half->height = half_camera->height;
  half->pixels.resize(size_t(half->width) * size_t(half->height));
  for (int y = 0; y < half->height; ++y) {
    const uint16_t* row = depth.pixels.data() + size_t(2 * y) * size_t(depth.width);
    uint16_t* out = half->pixels.data() + size_t(y) * size_t(half->width);
    for (int x = 0; x < half->width; ++x) out[x] = row[2 * x];
  }
}

}  // namespace skimap::perception
