// image_transport's `compressedDepth` messages (a sensor_msgs/CompressedImage on a depth
// topic's /compressedDepth) as the depth image they hold, so a bag or a live camera
// recorded through that transport streams like raw depth.
//
// The format, as the compressed_depth_image_transport plugin writes it (its documentation
// and sources, ROS 1 Noetic and ROS 2; our own implementation):
//   - `format` is "<encoding>; compressedDepth <codec>": encoding 16UC1 (millimetres) or
//     32FC1 (metres), codec "png" or "rvl"; older writers omit the codec ("16UC1;
//     compressedDepth") or the whole suffix, meaning PNG;
//   - `data` starts with a 12-byte header, little-endian: int32 format (0, the only one
//     defined) and two float32 quantisation parameters A and B, then the image: a 16-bit
//     greyscale PNG, or for RVL a uint32 width and height followed by an RVL stream
//     (codec/rvl_codec.h: the same layout);
//   - 16UC1: the image holds the depth in millimetres (0 = none);
//   - 32FC1: it holds quantised inverse depth q; depth in metres = A / (q - B) for q != 0,
//     q = 0 meaning no measurement.
//
// Thread safety: pure functions.
#ifndef ROS_BAG_COMPRESSED_DEPTH_H_
#define ROS_BAG_COMPRESSED_DEPTH_H_

#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>

#include <cstdint>
#include <string>

#include "absl/status/statusor.h"

namespace skimap::bag {

// The depth image a compressedDepth message holds: 16UC1 in millimetres, little-endian,
// the message's header; 32FC1 input becomes millimetres as ros_frames.h converts 32FC1
// (NaN, inf, <= 0 and beyond 65.535 m become 0). InvalidArgument naming `topic` and the
// field for a format that is not compressedDepth or names another encoding or codec, data
// shorter than its header, a header format other than 0, non-finite quantisation
// parameters, an image that does not decode (not a 16-bit greyscale PNG, a corrupt RVL
// stream) or whose size is 0 or above kMaxImageSide (ros_frames.h), or, when
// `expected_width` and `expected_height` are given (not 0: the camera_info's size), another
// size than those. Sizes are checked before anything is decoded: with the expected size
// given, a message of a few bytes cannot make it allocate more than that image.
absl::StatusOr<sensor_msgs::Image> DecodeCompressedDepth(const sensor_msgs::CompressedImage& msg,
                                                         const std::string& topic,
                                                         uint32_t expected_width = 0,
                                                         uint32_t expected_height = 0);

}  // namespace skimap::bag

#endif  // ROS_BAG_COMPRESSED_DEPTH_H_
