// ROS 1 bags through the rosbag C++ API (bag_reader.h). The library throws on a bad bag
// (rosbag::BagException and its kin, ros::serialization exceptions, std::bad_alloc for an
// absurd length): every call into it is wrapped and its exceptions become statuses.
#include <rosbag/bag.h>
#include <rosbag/query.h>
#include <rosbag/view.h>

#include <exception>
#include <map>
#include <set>

#include "absl/strings/str_cat.h"
#include "ros/bag/bag_reader.h"

namespace skimap::bag {
namespace {

class Ros1Bag final : public BagReader {
 public:
  explicit Ros1Bag(std::string path) : path_(std::move(path)) {}

  absl::Status Open() {
    try {
      bag_.open(path_, rosbag::bagmode::Read);
      rosbag::View all(bag_);
      std::map<std::string, BagTopic> by_name;
      for (const rosbag::ConnectionInfo* c : all.getConnections()) {
        BagTopic& t = by_name[c->topic];
        t.name = c->topic;
        t.type = c->datatype;
      }
      for (auto& [name, topic] : by_name) {
        rosbag::View one(bag_, rosbag::TopicQuery(name));
        topic.count = one.size();
        topics_.push_back(std::move(topic));
      }
    } catch (const std::exception& e) {
      return absl::DataLossError(absl::StrCat(path_, ": not a readable ROS 1 bag: ", e.what()));
    }
    return absl::OkStatus();
  }

  const std::vector<BagTopic>& topics() const override { return topics_; }

  absl::Status ForEach(const std::vector<std::string>& topics,
                       const std::function<absl::Status(const BagMessage&)>& fn) override {
    std::map<std::string, std::string> types;
    for (const std::string& name : topics) {
      const BagTopic* topic = Find(name);
      if (topic == nullptr) {
        return absl::InvalidArgumentError(absl::StrCat(path_, ": no topic ", name));
      }
      if (topic->type != kImageType && topic->type != kCompressedImageType &&
          topic->type != kCameraInfoType && topic->type != kTfType) {
        return absl::InvalidArgumentError(absl::StrCat(path_, ": topic ", name, " is a ",
                                                       topic->type, ", not a type frames use"));
      }
      types[name] = topic->type;
    }
    std::string where;  // the message being read, for errors
    try {
      rosbag::View view(bag_, rosbag::TopicQuery(topics));
      uint64_t index = 0;
      for (const rosbag::MessageInstance& m : view) {
        const std::string& topic = m.getTopic();
        where = absl::StrCat("message ", index++, " on ", topic, " at ", m.getTime().toSec(), " s");
        BagMessage out;
        out.topic = &topic;
        out.time = m.getTime();
        const std::string& type = m.getDataType();
        bool decoded = false;
        if (type == kImageType) {
          decoded = (out.image = m.instantiate<sensor_msgs::Image>()) != nullptr;
        } else if (type == kCompressedImageType) {
          decoded = (out.compressed = m.instantiate<sensor_msgs::CompressedImage>()) != nullptr;
        } else if (type == kCameraInfoType) {
          decoded = (out.info = m.instantiate<sensor_msgs::CameraInfo>()) != nullptr;
        } else if (type == kTfType) {
          decoded = (out.tf = m.instantiate<tf2_msgs::TFMessage>()) != nullptr;
        }
        if (!decoded) {
          return absl::InvalidArgumentError(absl::StrCat(path_, ": ", where, ": a ", type,
                                                         " whose definition (md5sum ",
                                                         m.getMD5Sum(), ") is not this ROS's"));
        }
        if (absl::Status s = fn(out); !s.ok()) return s;
      }
    } catch (const std::exception& e) {
      return absl::DataLossError(
          absl::StrCat(path_, ": ", where.empty() ? "reading the index" : where, ": ", e.what()));
    }
    return absl::OkStatus();
  }

 private:
  const BagTopic* Find(const std::string& name) const {
    for (const BagTopic& t : topics_) {
      if (t.name == name) return &t;
    }
    return nullptr;
  }

  const std::string path_;
  rosbag::Bag bag_;
  std::vector<BagTopic> topics_;
};

}  // namespace

absl::StatusOr<std::unique_ptr<BagReader>> OpenRos1Bag(const std::string& path) {
  auto bag = std::make_unique<Ros1Bag>(path);
  if (absl::Status s = bag->Open(); !s.ok()) return s;
  return bag;
}

}  // namespace skimap::bag
