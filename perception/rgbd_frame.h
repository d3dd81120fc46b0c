// RgbdFrame: one decoded RGB-D frame with its camera model and pose, and its validation.
//
// Conventions: pinhole camera with pixel centres at integer coordinates (OpenCV / BOP);
// camera frame x right, y down, z forward; `pose` maps camera to world
// (p_world = rotation * p_camera + translation), metres, world z up.
//
// Thread safety: plain values.
#ifndef PERCEPTION_RGBD_FRAME_H_
#define PERCEPTION_RGBD_FRAME_H_

#include <optional>

#include "Eigen/Geometry"
#include "absl/status/status.h"
#include "codec/image_codec.h"

namespace skimap::perception {

struct PinholeCamera {
  double fx = 0, fy = 0;  // focal lengths, pixels
  double cx = 0, cy = 0;  // principal point, pixels
  int width = 0, height = 0;
};

// World <- camera rigid transform.
struct CameraPose {
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();  // (w, x, y, z), unit
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();         // metres
};

struct RgbdFrame {
  PinholeCamera camera;
  CameraPose pose;
  DepthImage depth;                 // camera.width x camera.height
  double depth_scale = 0;           // metres per depth unit, > 0
  std::optional<ColorImage> color;  // same size as depth; none = grey voxels
};

// Quaternion norms further than this from 1 are rejected (no silent normalization).
inline constexpr double kQuaternionNormTolerance = 1e-3;
// Plausible cameras: each field of view in [1, 170] degrees, the principal point inside the
// image widened by half its size on every side.
inline constexpr double kMinFovDegrees = 1;
inline constexpr double kMaxFovDegrees = 170;

// OK, or InvalidArgument naming the first bad field with the API's field names:
// "intrinsics.fx must be > 0", "pose.rotation is not a unit quaternion", ...
// ValidateCamera also refuses implausible cameras (kMinFovDegrees..kMaxFovDegrees, the
// principal point's range above).
absl::Status ValidateCamera(const PinholeCamera& camera);
absl::Status ValidatePose(const CameraPose& pose);
// Camera, pose, depth_scale and that the images match the camera size.
absl::Status ValidateFrame(const RgbdFrame& frame);

// The pose as a world <- camera transform.
Eigen::Isometry3d ToIsometry(const CameraPose& pose);

// Every second pixel of every second row of `depth` (pixel (x, y) is full pixel (2x, 2y)),
// and `camera`'s intrinsics halved to match. REQUIRES: depth is camera.width x
// camera.height.
void HalfResolution(const DepthImage& depth, const PinholeCamera& camera, DepthImage* half,
                    PinholeCamera* half_camera);

}  // namespace skimap::perception

#endif  // PERCEPTION_RGBD_FRAME_H_
