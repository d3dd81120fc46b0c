#include "ros/bag/ros2_messages.h"

#include <boost/make_shared.hpp>

#include "absl/strings/str_cat.h"
#include "ros/bag/cdr_messages.h"

namespace skimap::bag {
namespace {

template <typename T>
absl::Status Decode(std::string_view data, const std::string& where,
                    boost::shared_ptr<const T>* out) {
  auto msg = boost::make_shared<T>();
  if (absl::Status s = DecodeCdr(data, msg.get()); !s.ok()) {
    return absl::InvalidArgumentError(absl::StrCat(where, ": ", s.message()));
  }
  *out = std::move(msg);
  return absl::OkStatus();
}

}  // namespace

std::string Ros1TypeName(const std::string& ros2_type) {
  const size_t msg = ros2_type.find("/msg/");
  if (msg == std::string::npos) return ros2_type;
  return absl::StrCat(ros2_type.substr(0, msg), "/", ros2_type.substr(msg + 5));
}

absl::Status AddRos2Topic(const std::string& file, const std::string& name, const std::string& type,
                          std::map<std::string, BagTopic>* topics) {
  BagTopic& t = (*topics)[name];
  if (!t.name.empty() && t.type != type) {
    return absl::InvalidArgumentError(
        absl::StrCat(file, ": topic ", name, " is a ", type, " here and a ", t.type, " before"));
  }
  t.name = name;
  t.type = type;
  return absl::OkStatus();
}

absl::Status CheckRos2Topics(const std::string& bag, const std::vector<BagTopic>& topics,
                             const std::map<std::string, std::string>& encodings,
                             const std::vector<std::string>& asked) {
  for (const std::string& name : asked) {
    const BagTopic* topic = nullptr;
    for (const BagTopic& t : topics) {
      if (t.name == name) topic = &t;
    }
    if (topic == nullptr) return absl::InvalidArgumentError(absl::StrCat(bag, ": no topic ", name));
    if (!IsFrameType(topic->type)) {
      return absl::InvalidArgumentError(
          absl::StrCat(bag, ": topic ", name, " is a ", topic->type, ", not a type frames use"));
    }
    const auto e = encodings.find(name);
    const std::string encoding = e == encodings.end() ? "" : e->second;
    if (encoding != "cdr") {
      return absl::InvalidArgumentError(
          absl::StrCat(bag, ": topic ", name, " has message encoding \"", encoding, "\", not cdr"));
    }
  }
  return absl::OkStatus();
}

absl::Status DecodeRos2Message(const std::string& type, std::string_view data,
                               const std::string& where, BagMessage* out) {
  if (type == kImageType) return Decode(data, where, &out->image);
  if (type == kCompressedImageType) return Decode(data, where, &out->compressed);
  if (type == kCameraInfoType) return Decode(data, where, &out->info);
  if (type == kTfType) return Decode(data, where, &out->tf);
  return absl::InvalidArgumentError(absl::StrCat(where, ": type ", type, " is not one frames use"));
}

}  // namespace skimap::bag
