// ROS 2 bags in MCAP (bag_reader.h): one file, or the .mcap files of a rosbag2 folder in
// name order (a split recording), over the own MCAP reader and CDR decoders.
#include <boost/make_shared.hpp>
#include <map>

#include "absl/strings/str_cat.h"
#include "ros/bag/bag_reader.h"
#include "ros/bag/cdr_messages.h"
#include "ros/bag/mcap_reader.h"

namespace skimap::bag {
namespace {

// "sensor_msgs/msg/Image" -> "sensor_msgs/Image"; other names unchanged.
std::string Ros1TypeName(const std::string& schema) {
  const size_t msg = schema.find("/msg/");
  if (msg == std::string::npos) return schema;
  return absl::StrCat(schema.substr(0, msg), "/", schema.substr(msg + 5));
}

template <typename T>
absl::Status Decode(const McapMessage& m, const std::string& file,
                    boost::shared_ptr<const T>* out) {
  auto msg = boost::make_shared<T>();
  if (absl::Status s = DecodeCdr(m.data, msg.get()); !s.ok()) {
    return absl::InvalidArgumentError(absl::StrCat(file, ": message on ", m.channel->topic,
                                                   " (record at offset ", m.record_offset,
                                                   "): ", s.message()));
  }
  *out = std::move(msg);
  return absl::OkStatus();
}

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
        BagTopic& t = by_name[c.topic];
        const std::string type = Ros1TypeName(c.schema_name);
        if (!t.name.empty() && t.type != type) {
          return absl::InvalidArgumentError(absl::StrCat(file, ": topic ", c.topic, " is a ", type,
                                                         " here and a ", t.type, " before"));
        }
        t.name = c.topic;
        t.type = type;
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
    for (const std::string& name : topics) {
      const BagTopic* topic = Find(name);
      if (topic == nullptr) {
        return absl::InvalidArgumentError(absl::StrCat(Name(), ": no topic ", name));
      }
      if (topic->type != kImageType && topic->type != kCompressedImageType &&
          topic->type != kCameraInfoType && topic->type != kTfType) {
        return absl::InvalidArgumentError(absl::StrCat(Name(), ": topic ", name, " is a ",
                                                       topic->type, ", not a type frames use"));
      }
      if (encodings_[name] != "cdr") {
        return absl::InvalidArgumentError(absl::StrCat(
            Name(), ": topic ", name, " has message encoding \"", encodings_[name], "\", not cdr"));
      }
    }
    for (size_t i = 0; i < readers_.size(); ++i) {
      const std::string& file = files_[i];
      absl::Status s = readers_[i]->ForEachMessage(topics, [&](const McapMessage& m) {
        BagMessage out;
        out.topic = &m.channel->topic;
        out.time.fromNSec(m.log_time_ns);
        const std::string type = Ros1TypeName(m.channel->schema_name);
        absl::Status d;
        if (type == kImageType) {
          d = Decode(m, file, &out.image);
        } else if (type == kCompressedImageType) {
          d = Decode(m, file, &out.compressed);
        } else if (type == kCameraInfoType) {
          d = Decode(m, file, &out.info);
        } else if (type == kTfType) {
          d = Decode(m, file, &out.tf);
        } else {
          d = absl::InvalidArgumentError(
              absl::StrCat(file, ": topic ", m.channel->topic, " changed its type to ", type));
        }
        if (!d.ok()) return d;
        return fn(out);
      });
      if (!s.ok()) return s;
    }
    return absl::OkStatus();
  }

 private:
  std::string Name() const { return files_.size() == 1 ? files_[0] : files_[0] + " ..."; }
  const BagTopic* Find(const std::string& name) const {
    for (const BagTopic& t : topics_) {
      if (t.name == name) return &t;
    }
    return nullptr;
  }

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
