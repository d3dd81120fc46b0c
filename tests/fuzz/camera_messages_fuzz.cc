// Fuzz target: camera messages before they become frames (ros/bag): image_transport's
// compressedDepth (compressed_depth.h) and the undistortion a camera_info asks for
// (rectify.h).
//
// Input: a control byte, then
//   - even: a format selector byte and the message's data (the 12-byte header, then a PNG
//     or an RVL stream with its size): DecodeCompressedDepth. Invariant: a decoded image
//     is 16UC1, 1..8192 pixels a side, its data exactly width x height x 2 bytes.
//   - odd: a distortion model selector, a coefficient count (0..15) and that many doubles:
//     Rectify on a 32x24 frame with raw colour. Invariant: the frame keeps its size and
//     raw colour.
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "ros/bag/compressed_depth.h"
#include "ros/bag/rectify.h"
#include "tests/fuzz/fuzz_input.h"

namespace skimap::fuzz {
namespace {

const char* const kFormats[] = {"16UC1; compressedDepth png", "16UC1; compressedDepth rvl",
                                "32FC1; compressedDepth png", "32FC1; compressedDepth rvl",
                                "16UC1; compressedDepth",     "16UC1",
                                "32FC1; compressedDepth",     "mono16; compressedDepth rvl"};
const char* const kModels[] = {"plumb_bob", "rational_polynomial", "equidistant", "", "other"};

void Decode(FuzzInput& in) {
  sensor_msgs::CompressedImage message;
  message.format = kFormats[in.U8() % (sizeof kFormats / sizeof *kFormats)];
  const std::string_view data = in.Rest();
  message.data.assign(data.begin(), data.end());
  absl::StatusOr<sensor_msgs::Image> depth = bag::DecodeCompressedDepth(message, "/d");
  if (!depth.ok()) return;
  if (depth->encoding != "16UC1") Fail("encoding");
  if (depth->width < 1 || depth->height < 1 || depth->width > 8192 || depth->height > 8192) {
    Fail("size");
  }
  if (depth->step != depth->width * 2 ||
      depth->data.size() != size_t(depth->width) * depth->height * 2) {
    Fail("data size");
  }
}

void Rectify(FuzzInput& in) {
  constexpr int kWidth = 32, kHeight = 24;
  sensor_msgs::CameraInfo info;
  info.width = kWidth;
  info.height = kHeight;
  info.distortion_model = kModels[in.U8() % (sizeof kModels / sizeof *kModels)];
  const int count = in.U8() % 16;
  for (int i = 0; i < count; ++i) {
    uint64_t bits = uint64_t{in.U32()} | uint64_t{in.U32()} << 32;
    double d;
    std::memcpy(&d, &bits, 8);
    info.D.push_back(d);
  }
  info.K = {40, 0, 16, 0, 40, 12, 0, 0, 1};
  bag::RosFrame frame;
  frame.width = kWidth;
  frame.height = kHeight;
  frame.depth_mm.assign(kWidth * kHeight, 1000);
  frame.frame.set_color(std::string(kWidth * kHeight * 3, '\x7f'));
  frame.frame.set_color_encoding(v1::COLOR_ENCODING_RAW_RGB8);
  bag::Rectifier rectifier;
  if (!rectifier.Rectify(info, "/i", &frame).ok()) return;
  if (frame.depth_mm.size() != size_t(kWidth) * kHeight) Fail("depth size");
  if (frame.frame.color().size() != size_t(kWidth) * kHeight * 3 ||
      frame.frame.color_encoding() != v1::COLOR_ENCODING_RAW_RGB8) {
    Fail("colour");
  }
}

}  // namespace
}  // namespace skimap::fuzz

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  skimap::fuzz::FuzzInput in(data, size);
  if (in.U8() % 2 == 0) {
    skimap::fuzz::Decode(in);
  } else {
    skimap::fuzz::Rectify(in);
  }
  return 0;
}
