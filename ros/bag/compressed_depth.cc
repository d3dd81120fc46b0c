#include "ros/bag/compressed_depth.h"

#include <cmath>
#include <cstring>
#include <string_view>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/string_view.h"
#include "codec/image_codec.h"
#include "codec/image_header.h"
#include "codec/rvl_codec.h"
#include "ros/bag/ros_frames.h"

namespace skimap::bag {
namespace {

constexpr size_t kHeaderBytes = 12;  // int32 format, float32 A, float32 B

enum class Codec { kPng, kRvl };

struct Format {
  bool metres = false;  // 32FC1 quantised inverse depth, else 16UC1 millimetres
  Codec codec = Codec::kPng;
};

absl::StatusOr<Format> ParseFormat(const std::string& format, const std::string& topic) {
  const size_t semicolon = format.find(';');
  const absl::string_view encoding =
      absl::StripAsciiWhitespace(absl::string_view(format).substr(0, semicolon));
  Format out;
  if (semicolon != std::string::npos) {
    const absl::string_view rest =
        absl::StripAsciiWhitespace(absl::string_view(format).substr(semicolon + 1));
    if (rest == "compressedDepth" || rest == "compressedDepth png") {
      out.codec = Codec::kPng;
    } else if (rest == "compressedDepth rvl") {
      out.codec = Codec::kRvl;
    } else {
      return absl::InvalidArgumentError(absl::StrCat(
          topic, ": format \"", format,
          "\" is not compressedDepth (\"16UC1; compressedDepth png\" or \"... rvl\", or "
          "32FC1)"));
    }
  }
  if (encoding == "16UC1" || encoding == "mono16") {
    out.metres = false;
  } else if (encoding == "32FC1") {
    out.metres = true;
  } else {
    return absl::InvalidArgumentError(absl::StrCat(topic, ": format \"", format,
                                                   "\" names depth encoding \"", encoding,
                                                   "\" (compressedDepth holds 16UC1 or 32FC1)"));
  }
  return out;
}

absl::Status CheckSize(int64_t width, int64_t height, const std::string& topic,
                       uint32_t expected_width, uint32_t expected_height) {
  if (width <= 0 || height <= 0 || width > kMaxImageSide || height > kMaxImageSide) {
    return absl::InvalidArgumentError(absl::StrCat(topic, ": compressedDepth image is ", width, "x",
                                                   height, ", outside 1..", kMaxImageSide));
  }
  if (expected_width != 0 && (width != expected_width || height != expected_height)) {
    return absl::InvalidArgumentError(absl::StrCat(topic, ": compressedDepth image is ", width, "x",
                                                   height, ", camera_info is for ", expected_width,
                                                   "x", expected_height));
  }
  return absl::OkStatus();
}

uint32_t ReadU32(const uint8_t* p) {
  return uint32_t{p[0]} | uint32_t{p[1]} << 8 | uint32_t{p[2]} << 16 | uint32_t{p[3]} << 24;
}

float ReadF32(const uint8_t* p) {
  const uint32_t bits = ReadU32(p);
  float f;
  std::memcpy(&f, &bits, 4);
  return f;
}

}  // namespace

absl::StatusOr<sensor_msgs::Image> DecodeCompressedDepth(const sensor_msgs::CompressedImage& msg,
                                                         const std::string& topic,
                                                         uint32_t expected_width,
                                                         uint32_t expected_height) {
  absl::StatusOr<Format> format = ParseFormat(msg.format, topic);
  if (!format.ok()) return format.status();
  if (msg.data.size() <= kHeaderBytes) {
    return absl::InvalidArgumentError(absl::StrCat(topic, ": data holds ", msg.data.size(),
                                                   " bytes, less than the ", kHeaderBytes,
                                                   "-byte compressedDepth header and an image"));
  }
  const uint8_t* data = msg.data.data();
  const uint32_t header_format = ReadU32(data);
  if (header_format != 0) {
    return absl::InvalidArgumentError(
        absl::StrCat(topic, ": compressedDepth header format is ", int32_t(header_format),
                     ", not 0 (inverse depth, the only one defined)"));
  }
  const float a = ReadF32(data + 4), b = ReadF32(data + 8);
  if (format->metres && (!std::isfinite(a) || !std::isfinite(b))) {
    return absl::InvalidArgumentError(absl::StrCat(
        topic, ": compressedDepth quantisation parameters ", a, ", ", b, " are not finite"));
  }
  const absl::string_view image(reinterpret_cast<const char*>(data + kHeaderBytes),
                                msg.data.size() - kHeaderBytes);
  const std::string what = absl::StrCat(topic, ": compressedDepth");
  perception::DepthImage depth;
  if (format->codec == Codec::kPng) {
    absl::StatusOr<perception::ImageHeader> header =
        perception::ReadImageHeader(perception::ImageFormat::kPng, image, what);
    if (!header.ok()) return header.status();
    if (absl::Status s =
            CheckSize(header->width, header->height, topic, expected_width, expected_height);
        !s.ok()) {
      return s;
    }
    absl::Status s = perception::DecodeDepthInto(perception::DepthCodec::kPng16,
                                                 std::string_view(image.data(), image.size()),
                                                 int(header->width), int(header->height), &depth);
    if (!s.ok()) return absl::InvalidArgumentError(absl::StrCat(what, " PNG: ", s.message()));
  } else {
    if (image.size() < 8) {
      return absl::InvalidArgumentError(
          absl::StrCat(what, " RVL: ", image.size(), " bytes, less than its 8-byte size"));
    }
    const auto* p = reinterpret_cast<const uint8_t*>(image.data());
    const uint32_t width = ReadU32(p), height = ReadU32(p + 4);
    if (absl::Status s = CheckSize(width, height, topic, expected_width, expected_height);
        !s.ok()) {
      return s;
    }
    depth.width = int(width);
    depth.height = int(height);
    depth.pixels.resize(size_t(width) * height);
    absl::Status s = perception::DecodeRvl(std::string_view(image.data() + 8, image.size() - 8),
                                           depth.pixels.data(), depth.pixels.size());
    if (!s.ok()) return absl::InvalidArgumentError(absl::StrCat(what, " RVL: ", s.message()));
  }

  sensor_msgs::Image out;
  out.header = msg.header;
  out.width = uint32_t(depth.width);
  out.height = uint32_t(depth.height);
  out.encoding = "16UC1";
  out.is_bigendian = 0;
  out.step = out.width * 2;
  out.data.resize(depth.pixels.size() * 2);
  if (format->metres) {
    // Quantised inverse depth to millimetres, as ros_frames.h converts 32FC1.
    for (uint16_t& q : depth.pixels) q = q == 0 ? 0 : MillimetresOf(a / (float(q) - b));
  }
  for (size_t i = 0; i < depth.pixels.size(); ++i) {
    out.data[2 * i] = uint8_t(depth.pixels[i]);
    out.data[2 * i + 1] = uint8_t(depth.pixels[i] >> 8);
  }
  return out;
}

}  // namespace skimap::bag
