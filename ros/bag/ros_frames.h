// ROS camera messages as an API frame: a depth image (sensor_msgs/Image 16UC1 in mm or
// 32FC1 in m, REP 118), an optional colour image (Image rgb8 / bgr8 / rgba8 / bgra8 /
// mono8, or a CompressedImage holding a JPEG or PNG), the depth camera's CameraInfo and
// the camera's pose in the fixed frame. Shared by the bag readers (bag_frames.h) and the
// skimap-ros bridge, so a bag and a live robot make the same frames.
//
// The depth image is assumed registered to the colour image (same size, same camera:
// depth_registered / aligned_depth_to_color topics). CameraInfo's K is the frame's
// intrinsics; its distortion is not looked at here: Rectifier (rectify.h) undoes it on
// the frame made. Every check names the topic and the field:
//   "/camera/depth/image_raw: data holds 1000 bytes, height 480 x step 1280 needs 614400".
//
// Thread safety: pure functions of their arguments.
#ifndef ROS_BAG_ROS_FRAMES_H_
#define ROS_BAG_ROS_FRAMES_H_

#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "ros/bag/bag_frames.h"
#include "skimap/v1/frames.pb.h"

namespace skimap::bag {

// A colour message of either kind (at most one pointer set; neither: no colour).
struct ColorMessage {
  const sensor_msgs::Image* image = nullptr;
  const sensor_msgs::CompressedImage* compressed = nullptr;
  std::string topic;  // for errors
};

// Largest image side accepted (the server's limit).
inline constexpr uint32_t kMaxImageSide = 8192;

// A depth in metres (32FC1) as millimetres: NaN, inf, <= 0 and beyond 65.535 m become 0
// (no measurement).
inline uint16_t MillimetresOf(float metres) {
  const double mm = double(metres) * 1000.0;
  return std::isfinite(mm) && mm > 0 && mm < 65535.5 ? static_cast<uint16_t>(std::lround(mm)) : 0;
}

// Checks and converts. InvalidArgument naming the topic and field for: an unsupported
// depth or colour encoding, a size of 0 or above kMaxImageSide, a step too small for the
// width, data shorter than height x step, CameraInfo of another size than the depth image
// or with a non-positive focal length, a colour image of another size than the depth
// image, a compressed colour image that is neither JPEG nor PNG. 32FC1 depth: NaN, inf,
// <= 0 and beyond 65.535 m become 0.
absl::StatusOr<RosFrame> MakeRosFrame(const sensor_msgs::Image& depth,
                                      const std::string& depth_topic, const ColorMessage& color,
                                      const sensor_msgs::CameraInfo& info,
                                      const std::string& info_topic,
                                      const Eigen::Isometry3d& T_world_camera);

}  // namespace skimap::bag

#endif  // ROS_BAG_ROS_FRAMES_H_
