#include "perception/rgbd_frame.h"

#include <cmath>

#include "absl/strings/str_cat.h"

namespace skimap::perception {
namespace {

constexpr int kMaxSide = 8192;

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
  if (c.width <= 0 || c.width > kMaxSide) {
    return absl::InvalidArgumentError(absl::StrCat("intrinsics.width must be in 1..", kMaxSide));
  }
  if (c.height <= 0 || c.height > kMaxSide) {
    return absl::InvalidArgumentError(absl::StrCat("intrinsics.height must be in 1..", kMaxSide));
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

}  // namespace skimap::perception
