// ROS 2 bags in MCAP (bag_reader.h): one file, or the .mcap files of a rosbag2 folder in
// name order (a split recording), over the own MCAP reader and CDR decoders.
#include <map>

#include "absl/strings/str_cat.h"
#include "ros/bag/bag_reader.h"
#include "ros/bag/mcap_reader.h"
#include "ros/bag/ros2_messages.h"

namespace skimap::bag {
namespace {

class McapBag final : public BagReader {
 public:
  absl::Status Open(const std::vector<std::string>& files) {
    std::map<std::string, BagTopic> by_name;
    for (const std::string& file : files) {
      absl::StatusOr<std::unique_ptr<McapReader>> reader = McapReader::Open(file);
      if (!reader.ok()) return reader.status();
      absl::StatusOr<std::vector<McapChannel>> channels = (*reader)->Channels();
      if (!channels.ok()) return channels.status();
      for (const McapChannel& c : *channels) {
        const std::string type = Ros1TypeName(c.schema_name);
        if (absl::Status s = AddRos2Topic(file, c.topic, type, &by_name); !s.ok()) return s;
        encodings_[c.topic] = c.message_encoding;
      }
      readers_.push_back(*std::move(reader));
      files_.push_back(file);
    }
    for (auto& [name, topic] : by_name) topics_.push_back(std::move(topic));
    return absl::OkStatus();
  }

  const std::vector<BagTopic>& topics() const override { return topics_; }

  absl::Status ForEach(const std::vector<std::string>& topics,
                       const std::function<absl::Status(const BagMessage&)>& fn) override {
    if (absl::Status s = CheckRos2Topics(Name(), topics_, encodings_, topics); !s.ok()) return s;
    for (size_t i = 0; i < readers_.size(); ++i) {
      const std::string& file = files_[i];
      absl::Status s = readers_[i]->ForEachMessage(topics, [&](const McapMessage& m) {
        BagMessage out;
        out.topic = &m.channel->topic;
        out.time.fromNSec(m.log_time_ns);
        absl::Status d =
            DecodeRos2Message(Ros1TypeName(m.channel->schema_name), m.data,
                              absl::StrCat(file, ": message on ", m.channel->topic,
                                           " (record at offset ", m.record_offset, ")"),
                              &out);
        if (!d.ok()) return d;
        return fn(out);
      });
      if (!s.ok()) return s;
    }
    return absl::OkStatus();
  }

 private:
  std::string Name() const { return files_.size() == 1 ? files_[0] : files_[0] + " ..."; }
  std::vector<std::string> files_;
  std::vector<std::unique_ptr<McapReader>> readers_;
  std::vector<BagTopic> topics_;
  std::map<std::string, std::string> encodings_;  // topic -> message encoding
};

}  // namespace

absl::StatusOr<std::unique_ptr<BagReader>> OpenMcapBag(const std::vector<std::string>& files) {
  auto bag = std::make_unique<McapBag>();
  if (absl::Status s = bag->Open(files); !s.ok()) return s;
  return bag;
}

}  // namespace skimap::bag
