// DecodeCdr: ROS 2 messages, serialised as CDR (what rosbag2 stores with message_encoding
// "cdr"), decoded into ROS 1's C++ type for the same message, so that one pipeline serves
// both kinds of bag.
//
//   sensor_msgs::Image image;
//   if (absl::Status s = DecodeCdr(message.data, &image); !s.ok()) return s;
//
// The format: a 4-byte encapsulation header (0x00 0x00: CDR big endian, 0x00 0x01: CDR
// little endian; the other two bytes are options, ignored), then the fields in order, each
// primitive aligned to its size (XCDR1: float64 to 8) relative to the byte after the header.
// Strings are a uint32 length counting a trailing NUL, then the bytes; sequences a uint32
// count, then the elements; fixed arrays just the elements. Trailing bytes are ignored, as
// CDR allows.
//
// ROS 2 -> ROS 1: builtin_interfaces/Time {sec, nanosec} -> ros::Time {sec, nsec} (negative
// sec and nanosec >= 1e9 are refused); std_msgs/Header gets seq = 0 (ROS 2 has none);
// CameraInfo's d, k, r, p -> D, K, R, P; bool -> uint8.
//
// Errors: InvalidArgument naming the message type and the field, e.g.
// "sensor_msgs/msg/Image.data: 921600 bytes declared, 812 left". A decoder never reads out of
// bounds and never allocates more than the input could hold (a sequence's count is checked
// against the bytes left before anything is reserved). On error *out is partly written.
//
// Thread safety: pure functions.
#ifndef ROS_BAG_CDR_MESSAGES_H_
#define ROS_BAG_CDR_MESSAGES_H_

#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>
#include <tf2_msgs/TFMessage.h>

#include <string_view>

#include "absl/status/status.h"

namespace skimap::bag {

// sensor_msgs/msg/Image.
[[nodiscard]] absl::Status DecodeCdr(std::string_view cdr, sensor_msgs::Image* out);
// sensor_msgs/msg/CompressedImage.
[[nodiscard]] absl::Status DecodeCdr(std::string_view cdr, sensor_msgs::CompressedImage* out);
// sensor_msgs/msg/CameraInfo (d, k, r, p -> D, K, R, P).
[[nodiscard]] absl::Status DecodeCdr(std::string_view cdr, sensor_msgs::CameraInfo* out);
// tf2_msgs/msg/TFMessage.
[[nodiscard]] absl::Status DecodeCdr(std::string_view cdr, tf2_msgs::TFMessage* out);

}  // namespace skimap::bag

#endif  // ROS_BAG_CDR_MESSAGES_H_
