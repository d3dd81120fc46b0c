// Fuzz target: camera messages before they become frames (ros/bag): image_transport's
// compressedDepth (compressed_depth.h) and the undistortion a camera_info asks for
// (rectify.h).
//
// Input: a control byte, then
//   - even: a format selector byte and the message's data (the 12-byte header, then a PNG
//     or an RVL stream with its size): DecodeCompressedDepth. Invariant: a decoded image
//     is 16UC1, 1..8192 pixels a side, its data exactly width x height x 2 bytes.
//   - odd: a size byte, a distortion model selector, a coefficient count (0..15) and that
//     many doubles, optionally a K of any bits: Rectify (one Rectifier for the run, so its
//     cache of maps is reached) on a frame of up to 39x34 with raw colour, now and then of
//     another size than the camera_info. Invariant: a frame rectified (D not all zero) had
//     the camera_info's size; every frame keeps its size and raw colour.
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

double Double(FuzzInput& in) {
  const uint64_t bits = uint64_t{in.U32()} | uint64_t{in.U32()} << 32;
  double d;
  std::memcpy(&d, &bits, 8);
  return d;
}

void Rectify(FuzzInput& in) {
  // One Rectifier for the whole run: its cache of maps is exercised across inputs.
  static bag::Rectifier rectifier;
  const uint8_t control = in.U8();
  const int width = 8 + control % 32, height = 6 + (control >> 5) * 4;
  sensor_msgs::CameraInfo info;
  info.width = width;
  info.height = height;
  info.distortion_model = kModels[in.U8() % (sizeof kModels / sizeof *kModels)];
  const int count = in.U8() % 16;
  for (int i = 0; i < count; ++i) info.D.push_back(Double(in));
  info.K = {40, 0, width / 2.0, 0, 40, height / 2.0, 0, 0, 1};
  if (in.U8() % 2 == 1) {  // a K of any bits: focal lengths, centre, skew
    for (int i : {0, 1, 2, 4, 5}) info.K[i] = Double(in);
  }
  bag::RosFrame frame;
  // Now and then a frame of another size than its camera_info: refused, never read past.
  frame.width = in.U8() % 8 == 0 ? width + 1 : width;
  frame.height = height;
  frame.depth_mm.assign(size_t(frame.width) * frame.height, 1000);
  frame.frame.set_color(std::string(size_t(frame.width) * frame.height * 3, '\x7f'));
  frame.frame.set_color_encoding(v1::COLOR_ENCODING_RAW_RGB8);
  if (!rectifier.Rectify(info, "/i", "/c", &frame).ok()) return;
  // Without distortion nothing is done (and nothing checked): any size stays as it was.
  if (bag::HasDistortion(info) && frame.width != width) Fail("a frame of another size");
  const size_t pixels = size_t(frame.width) * frame.height;
  if (frame.depth_mm.size() != pixels) Fail("depth size");
  if (frame.frame.color().size() != pixels * 3 ||
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
