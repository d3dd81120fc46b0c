// Depth and colour images and their wire encodings (the DepthEncoding / ColorEncoding of
// proto/skimap/v1/frames.proto).
//
//   absl::StatusOr<DepthImage> depth = DecodeDepth(DepthCodec::kPng16, bytes, 640, 480);
//   absl::StatusOr<std::string> packed = EncodeDepth(DepthCodec::kZstd, *depth);
//
// Every decoder checks the size an image claims against the expected width x height before
// it allocates or decodes anything (PNG / JPEG headers: image_header.h; a zstd frame's
// content size), checks the decoded result again, and returns InvalidArgument
// ("depth: ...", "color: ...") otherwise. Depth PNGs must be 16-bit greyscale; colour
// PNG / JPEG must have 8-bit samples; a JPEG without its EOI marker (truncated) is refused.
// PNG and JPEG decode through codec/image_files.h (libpng, libjpeg-turbo); no exception
// leaves these functions.
//
// Thread safety: free functions on values; safe from any thread.
#ifndef CODEC_IMAGE_CODEC_H_
#define CODEC_IMAGE_CODEC_H_

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"

namespace skimap::perception {

// Depth in sensor units, row-major; 0 = no measurement.
struct DepthImage {
  int width = 0, height = 0;
  std::vector<uint16_t> pixels;  // width * height
};

// 8-bit colour, row-major, R G B per pixel.
struct ColorImage {
  int width = 0, height = 0;
  std::vector<uint8_t> rgb;  // width * height * 3
};

enum class DepthCodec {
  kRawU16,  // little-endian uint16, row-major
  kPng16,   // 16-bit greyscale PNG
  kZstd,    // one zstd frame of the kRawU16 bytes
  kRvl,     // RVL (codec/rvl_codec.h)
};

enum class ColorCodec {
  kRawRgb8,  // R G B bytes, row-major
  kPng,
  kJpeg,
};

// Decodes `bytes` as a width x height depth image. InvalidArgument if the bytes do not
// decode, or decode to another size or pixel type.
absl::StatusOr<DepthImage> DecodeDepth(DepthCodec codec, std::string_view bytes, int width,
                                       int height);

// Decodes `bytes` as a width x height colour image (PNG/JPEG: grey or BGR(A) input is
// converted to RGB). InvalidArgument as for DecodeDepth.
absl::StatusOr<ColorImage> DecodeColor(ColorCodec codec, std::string_view bytes, int width,
                                       int height);

// As DecodeDepth / DecodeColor, into *out, reusing its buffer: no allocation for raw,
// zstd and RVL depth and raw colour once the buffer has grown to the size, and PNG / JPEG
// are decoded straight into it too. On error *out is
// unspecified.
absl::Status DecodeDepthInto(DepthCodec codec, std::string_view bytes, int width, int height,
                             DepthImage* out);
absl::Status DecodeColorInto(ColorCodec codec, std::string_view bytes, int width, int height,
                             ColorImage* out);

// Encodes a depth image (for clients, tests and benchmarks). InvalidArgument if the image
// is inconsistent; Internal if the codec fails.
absl::StatusOr<std::string> EncodeDepth(DepthCodec codec, const DepthImage& image);
// Encodes a colour image; JPEG at quality 90.
absl::StatusOr<std::string> EncodeColor(ColorCodec codec, const ColorImage& image);

}  // namespace skimap::perception

#endif  // CODEC_IMAGE_CODEC_H_
