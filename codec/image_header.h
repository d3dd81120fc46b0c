// What a PNG or JPEG header claims, read without decoding the image.
//
//   absl::StatusOr<ImageHeader> h = ReadImageHeader(ImageFormat::kPng, bytes, "depth");
//   if (h.ok() && h->width == 640 && h->height == 480) { ...decode... }
//
// Decoders trust the header to size their buffers (image_files.h refuses past 2^27 pixels), so a
// frame of a hundred bytes can claim 100000 x 100000 pixels. The image codecs read the
// header first and refuse an image whose size or pixel format is not the frame's before
// any decoder runs. PNG: the IHDR chunk (width, height, bit depth, colour type). JPEG: the
// first start-of-frame segment (SOF0..SOF15 but DHT/JPG/DAC), found by walking the marker
// segments; a JPEG must also end with its EOI marker (FF D9), which a truncated file lacks
// (libjpeg only warns on truncation and fills the missing rows with grey).
//
// Thread safety: pure functions.
#ifndef CODEC_IMAGE_HEADER_H_
#define CODEC_IMAGE_HEADER_H_

#include <cstdint>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace skimap::perception {

enum class ImageFormat { kPng, kJpeg };

struct ImageHeader {
  int64_t width = 0, height = 0;  // as claimed (up to 2^32 - 1 for PNG, 2^16 - 1 for JPEG)
  int bit_depth = 0;              // bits per sample: PNG 1..16, JPEG 8 or 12 (precision)
  int channels = 0;               // samples per pixel (PNG palette: 1; JPEG components)
};

// The header of `bytes` as `format`. InvalidArgument "<what>: ..." when the bytes are not
// such a file (bad signature, header cut short, no frame header, JPEG without EOI).
absl::StatusOr<ImageHeader> ReadImageHeader(ImageFormat format, absl::string_view bytes,
                                            absl::string_view what);

}  // namespace skimap::perception

#endif  // CODEC_IMAGE_HEADER_H_
