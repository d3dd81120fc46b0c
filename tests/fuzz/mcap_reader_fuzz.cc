// Fuzz target: ros/bag's MCAP reader (mcap_reader.h) and CDR decoders (cdr_messages.h).
//
// Input: an MCAP file as is (no control bytes; the seeds are small bags of
// tests/ros/mcap_writer). The reader walks it with chunks capped at 16 MiB, lists its
// channels, and every message whose schema is one of the four decoded types goes through
// DecodeCdr. Invariants: a message's channel is set and its data is no larger than a
// chunk may be; a decoded sequence is no larger than the message that held it.
#include <cstdint>
#include <string>
#include <string_view>

#include "ros/bag/cdr_messages.h"
#include "ros/bag/mcap_reader.h"
#include "tests/fuzz/fuzz_input.h"

namespace skimap::fuzz {
namespace {

constexpr uint64_t kMaxChunk = 16ull << 20;

absl::Status Decode(const bag::McapMessage& m) {
  if (m.channel == nullptr) Fail("a message without a channel");
  if (m.data.size() > kMaxChunk) Fail("a message larger than a chunk may be");
  const std::string& schema = m.channel->schema_name;
  const size_t size = m.data.size();
  if (schema == "sensor_msgs/msg/Image") {
    sensor_msgs::Image image;
    if (bag::DecodeCdr(m.data, &image).ok() && image.data.size() > size) Fail("Image.data");
  } else if (schema == "sensor_msgs/msg/CompressedImage") {
    sensor_msgs::CompressedImage image;
    if (bag::DecodeCdr(m.data, &image).ok() && image.data.size() > size) Fail("data");
  } else if (schema == "sensor_msgs/msg/CameraInfo") {
    sensor_msgs::CameraInfo info;
    if (bag::DecodeCdr(m.data, &info).ok() && info.D.size() * 8 > size) Fail("CameraInfo.d");
  } else if (schema == "tf2_msgs/msg/TFMessage") {
    tf2_msgs::TFMessage tf;
    if (bag::DecodeCdr(m.data, &tf).ok() && tf.transforms.size() * 72 > size) Fail("transforms");
  }
  return absl::OkStatus();
}

}  // namespace
}  // namespace skimap::fuzz

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace skimap;
  bag::McapReader::Options options;
  options.max_chunk_bytes = fuzz::kMaxChunk;
  auto reader = bag::McapReader::FromBytes(
      std::string_view(reinterpret_cast<const char*>(data), size), "fuzz.mcap", options);
  if (!reader.ok()) return 0;
  (void)(*reader)->Channels();
  (void)(*reader)->ForEachMessage({}, fuzz::Decode);
  return 0;
}
