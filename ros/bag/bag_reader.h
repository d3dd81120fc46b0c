// BagReader: the messages of a ROS recording that frames are made of, decoded into ROS 1's
// C++ message types whatever the bag's format:
//   - ROS 1 bags (.bag, "#ROSBAG V2.0"): read with the rosbag C++ API (ros1_bag.cc);
//   - ROS 2 bags: one MCAP file, or a rosbag2 folder (metadata.yaml and its .mcap files,
//     read in name order), CDR messages (mcap_bag.cc over mcap_reader.h and cdr_messages.h);
//     or rosbag2's older sqlite3 storage, one .db3 file or a folder of them (sqlite_bag.cc).
// The types read: sensor_msgs Image, CompressedImage, CameraInfo and tf2_msgs TFMessage
// (/tf and /tf_static). Types are named the ROS 1 way ("sensor_msgs/Image"); a ROS 2
// schema name "sensor_msgs/msg/Image" reads as that.
//
//   absl::StatusOr<std::unique_ptr<BagReader>> bag = OpenBag("run.mcap");
//   (*bag)->ForEach({"/tf"}, [](const BagMessage& m) { ...m.tf...; return absl::OkStatus(); });
//
// Thread safety: one caller at a time per reader.
#ifndef ROS_BAG_BAG_READER_H_
#define ROS_BAG_BAG_READER_H_

#include <ros/time.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>
#include <tf2_msgs/TFMessage.h>

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/statusor.h"

namespace skimap::bag {

inline constexpr char kImageType[] = "sensor_msgs/Image";
inline constexpr char kCompressedImageType[] = "sensor_msgs/CompressedImage";
inline constexpr char kCameraInfoType[] = "sensor_msgs/CameraInfo";
inline constexpr char kTfType[] = "tf2_msgs/TFMessage";

// True for the four types frames are made of (the ones ForEach decodes).
inline bool IsFrameType(const std::string& type) {
  return type == kImageType || type == kCompressedImageType || type == kCameraInfoType ||
         type == kTfType;
}

struct BagTopic {
  std::string name;
  std::string type;    // ROS 1 style, e.g. "sensor_msgs/Image"
  uint64_t count = 0;  // messages, when the bag's index says (0: not known)
};

// One decoded message; exactly one of the pointers is set, by the topic's type.
struct BagMessage {
  const std::string* topic = nullptr;
  ros::Time time;  // when it was recorded (not the header stamp)
  sensor_msgs::ImageConstPtr image;
  sensor_msgs::CompressedImageConstPtr compressed;
  sensor_msgs::CameraInfoConstPtr info;
  tf2_msgs::TFMessageConstPtr tf;
};

class BagReader {
 public:
  virtual ~BagReader() = default;
  // Every topic of the bag, by name.
  virtual const std::vector<BagTopic>& topics() const = 0;
  // Decodes every message of `topics` (each of one of the four types; InvalidArgument naming
  // a topic of another type or one the bag lacks) in record order, and calls `fn` with it.
  // Stops at the first problem of the bag (DataLoss for a truncated or corrupt record,
  // InvalidArgument for a message that does not decode: the message names the file, the
  // topic and, where the format has one, the record's offset) or the first non-OK status of
  // `fn`, returned as is.
  virtual absl::Status ForEach(const std::vector<std::string>& topics,
                               const std::function<absl::Status(const BagMessage&)>& fn) = 0;
};

// Opens a ROS 1 bag or a ROS 2 bag (an MCAP or sqlite3 file, or a rosbag2 folder of
// either), by its contents. NotFound for a missing path; InvalidArgument for a file that is
// none of these (naming it) or a folder without .mcap or .db3 files; DataLoss for a bag
// whose index, summary or database is corrupt.
absl::StatusOr<std::unique_ptr<BagReader>> OpenBag(const std::string& path);

// Implementations, for OpenBag.
absl::StatusOr<std::unique_ptr<BagReader>> OpenRos1Bag(const std::string& path);
absl::StatusOr<std::unique_ptr<BagReader>> OpenMcapBag(const std::vector<std::string>& files);
absl::StatusOr<std::unique_ptr<BagReader>> OpenSqliteBag(const std::vector<std::string>& files);

}  // namespace skimap::bag

#endif  // ROS_BAG_BAG_READER_H_
