// Fuzz target: every depth and colour codec of codec/image_codec.h and the PNG / JPEG
// header reader (image_header.h).
//
// Input: u8 codec (0-2 depth raw / PNG16 / zstd, 3-5 colour raw / PNG / JPEG, 6-7 the PNG /
// JPEG header alone, 8 depth RVL, 9-13 image_files.h's DecodeImage in each ImageMode), u16 width,
// u16 height (each taken modulo 512, plus 1), then the image bytes. A decoded image must have the
// asked size; a lossless codec must give the same image back after encoding it again; an image file
// that decodes must have the mode's pixel type and encode as PNG; a PNG the libdeflate fast
// path decodes must decode to the same pixels with libpng alone.
#include <cstdint>
#include <string>

#include "codec/image_codec.h"
#include "codec/image_files.h"
#include "codec/image_formats.h"
#include "codec/image_header.h"
#include "tests/fuzz/fuzz_input.h"

namespace skimap::fuzz {
namespace {

using perception::ColorCodec;
using perception::DepthCodec;

void Depth(DepthCodec codec, std::string_view bytes, int width, int height) {
  absl::StatusOr<perception::DepthImage> d = perception::DecodeDepth(codec, bytes, width, height);
  if (!d.ok()) return;
  if (d->width != width || d->height != height || d->pixels.size() != size_t(width) * height) {
    Fail("decoded depth image has another size than asked");
  }
  absl::StatusOr<std::string> again = perception::EncodeDepth(codec, *d);
  if (!again.ok()) Fail("a decoded depth image does not encode");
  absl::StatusOr<perception::DepthImage> back =
      perception::DecodeDepth(codec, *again, width, height);
  if (!back.ok() || back->pixels != d->pixels) Fail("depth codec round trip differs");
}

void Color(ColorCodec codec, std::string_view bytes, int width, int height) {
  absl::StatusOr<perception::ColorImage> c = perception::DecodeColor(codec, bytes, width, height);
  if (!c.ok()) return;
  if (c->width != width || c->height != height || c->rgb.size() != size_t(width) * height * 3) {
    Fail("decoded colour image has another size than asked");
  }
  absl::StatusOr<std::string> again = perception::EncodeColor(codec, *c);
  if (!again.ok()) Fail("a decoded colour image does not encode");
  absl::StatusOr<perception::ColorImage> back =
      perception::DecodeColor(codec, *again, width, height);
  if (!back.ok()) Fail("a re-encoded colour image does not decode");
  if (codec != ColorCodec::kJpeg && back->rgb != c->rgb) Fail("colour codec round trip differs");
}

void File(perception::ImageMode mode, std::string_view bytes) {
  // The PNG fast path against libpng: whatever it decodes, libpng decodes to the same
  // pixels (it declines everything else).
  cv::Mat fast;
  if (perception::image_formats::DecodePngFast(bytes, mode, &fast)) {
    cv::Mat reference;
    if (!perception::image_formats::DecodePngWithLibpng(bytes, mode, &reference).ok()) {
      Fail("the PNG fast path decoded bytes libpng refuses");
    }
    if (fast.size() != reference.size() || fast.type() != reference.type() ||
        cv::norm(fast, reference, cv::NORM_INF) != 0) {
      Fail("the PNG fast path and libpng decode different pixels");
    }
  }
  absl::StatusOr<cv::Mat> m = perception::DecodeImage(bytes, mode);
  if (!m.ok()) return;
  if (m->empty()) Fail("an image file decoded to an empty matrix");
  const bool eight = m->depth() == CV_8U;
  switch (mode) {
    case perception::ImageMode::kColor:
    case perception::ImageMode::kRgb:
      if (m->type() != CV_8UC3) Fail("colour mode gave another pixel type");
      break;
    case perception::ImageMode::kGrey:
      if (m->type() != CV_8UC1) Fail("grey mode gave another pixel type");
      break;
    case perception::ImageMode::kAnyDepth:
      if (m->channels() != 1) Fail("any-depth mode gave more than one channel");
      break;
    case perception::ImageMode::kUnchanged:
      if (!eight && m->depth() != CV_16U) Fail("a decoded image is neither 8- nor 16-bit");
      break;
  }
  if (!perception::EncodeImage(".png", *m).ok()) Fail("a decoded image does not encode as PNG");
}

}  // namespace
}  // namespace skimap::fuzz

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace skimap::fuzz;
  FuzzInput in(data, size);
  const int which = in.U8() % 14;
  const int width = in.U16() % 512 + 1;
  const int height = in.U16() % 512 + 1;
  const std::string_view bytes = in.Rest();
  switch (which) {
    case 0:
      Depth(DepthCodec::kRawU16, bytes, width, height);
      break;
    case 1:
      Depth(DepthCodec::kPng16, bytes, width, height);
      break;
    case 2:
      Depth(DepthCodec::kZstd, bytes, width, height);
      break;
    case 3:
      Color(ColorCodec::kRawRgb8, bytes, width, height);
      break;
    case 4:
      Color(ColorCodec::kPng, bytes, width, height);
      break;
    case 5:
      Color(ColorCodec::kJpeg, bytes, width, height);
      break;
    case 8:
      Depth(DepthCodec::kRvl, bytes, width, height);
      break;
    case 9:
    case 10:
    case 11:
    case 12:
    case 13:
      File(static_cast<skimap::perception::ImageMode>(which - 9), bytes);
      break;
    default: {
      const auto format = which == 6 ? skimap::perception::ImageFormat::kPng
                                     : skimap::perception::ImageFormat::kJpeg;
      absl::StatusOr<skimap::perception::ImageHeader> h = skimap::perception::ReadImageHeader(
          format, absl::string_view(bytes.data(), bytes.size()), "image");
      if (h.ok() && (h->width < 0 || h->height < 0)) Fail("negative image size in a header");
    }
  }
  return 0;
}
