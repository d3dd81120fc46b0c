// Fuzz target: server/core/maps/frame_decode.h, the validation and decoding of an API frame
// (intrinsics, pose, depth scale, every depth and colour encoding).
//
// Input: a serialized skimap.v1.Frame. A frame that decodes must satisfy what the rest of
// the pipeline relies on: the images have the intrinsics' size, the pose is a finite unit
// quaternion, the depth scale is finite and positive.
#include <cmath>
#include <cstdint>

#include "server/core/maps/frame_decode.h"
#include "tests/fuzz/fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using skimap::fuzz::Fail;
  skimap::v1::Frame frame;
  if (!frame.ParseFromArray(data, static_cast<int>(size))) return 0;
  absl::StatusOr<skimap::perception::RgbdFrame> f = skimap::server::DecodeFrame(frame);
  if (!f.ok()) {
    if (f.status().message().empty()) Fail("an error without a message");
    return 0;
  }
  const size_t pixels = size_t(f->camera.width) * f->camera.height;
  if (f->camera.width < 1 || f->camera.height < 1 || f->camera.width > 8192 ||
      f->camera.height > 8192 || f->depth.pixels.size() != pixels) {
    Fail("decoded depth does not match the intrinsics");
  }
  if (f->color.has_value() && f->color->rgb.size() != 3 * pixels) {
    Fail("decoded colour does not match the intrinsics");
  }
  if (!(f->depth_scale > 0) || !std::isfinite(f->depth_scale)) Fail("bad depth scale accepted");
  if (std::abs(f->pose.rotation.norm() - 1) > 1e-2 || !f->pose.translation.allFinite()) {
    Fail("bad pose accepted");
  }
  return 0;
}
