// What the two ROS 2 bag readers (MCAP: mcap_bag.cc, sqlite3: sqlite_bag.cc) share: ROS 2
// type names read the ROS 1 way, the check of the topics a caller asks for, and a CDR
// message decoded into the BagMessage pointer of its type (cdr_messages.h).
//
//   if (absl::Status s = CheckRos2Topics(name, topics, asked); !s.ok()) return s;
//   absl::Status s = DecodeRos2Message(type, data, "x.db3: message on /tf", &message);
//
// Thread safety: pure functions.
#ifndef ROS_BAG_ROS2_MESSAGES_H_
#define ROS_BAG_ROS2_MESSAGES_H_

#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "ros/bag/bag_reader.h"

namespace skimap::bag {

// "sensor_msgs/msg/Image" -> "sensor_msgs/Image"; other names unchanged.
std::string Ros1TypeName(const std::string& ros2_type);

// Adds topic `name` of ROS 1 type `type`, read from `file`, to `topics` (by name); the
// same topic in several files of a split bag must keep its type (InvalidArgument naming
// the file otherwise).
absl::Status AddRos2Topic(const std::string& file, const std::string& name, const std::string& type,
                          std::map<std::string, BagTopic>* topics);

// InvalidArgument, naming `bag`, for an asked topic the bag lacks, one of a type frames do
// not use, or one whose encoding (`encodings`: topic -> encoding) is not "cdr".
absl::Status CheckRos2Topics(const std::string& bag, const std::vector<BagTopic>& topics,
                             const std::map<std::string, std::string>& encodings,
                             const std::vector<std::string>& asked);

// Decodes CDR `data` of ROS 1 type name `type` (one of the four bag_reader.h reads) into
// the matching pointer of *out; InvalidArgument "<where>: <why>" otherwise.
absl::Status DecodeRos2Message(const std::string& type, std::string_view data,
                               const std::string& where, BagMessage* out);

}  // namespace skimap::bag

#endif  // ROS_BAG_ROS2_MESSAGES_H_
