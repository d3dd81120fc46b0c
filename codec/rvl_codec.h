// RVL: fast lossless compression of depth images (A. D. Wilson, "Fast Lossless Depth Image
// Compression", ISS 2017), the DEPTH_ENCODING_RVL of proto/skimap/v1/frames.proto.
//
//   std::string bytes = EncodeRvl(pixels.data(), pixels.size());
//   absl::Status s = DecodeRvl(bytes, out.data(), out.size());   // out sized by the caller
//
// The format (our own implementation from the paper's description; docs/formats.md, "RVL
// depth"): the pixels in row-major order are cut into alternating runs of zeros and of
// non-zero values. The stream is, until every pixel is covered:
//   VLE(zero run length), VLE(non-zero run length),
//   then for each non-zero pixel VLE(zigzag(pixel - previous non-zero pixel))
// with `previous` starting at 0. VLE writes a value 3 bits at a time, least significant
// group first, each group in a 4-bit nibble whose high bit says "more groups follow";
// zigzag maps a signed delta d to (d << 1) ^ (d >> 31). Nibbles fill 32-bit little-endian
// words from the most significant nibble down; the last word is padded with zero nibbles.
// Runs span rows, so any width works. A typical 640x480 sensor frame compresses 3-4x.
//
// The decoder refuses (InvalidArgument, "depth: RVL ...") anything the encoder would not
// write for `count` pixels: a length that is not a multiple of 4, a run past the last
// pixel, a run that is not maximal (an empty zero run but the first, an empty value run
// but the last), a value outside uint16 or a zero inside a non-zero run, an over-long or
// non-minimal VLE, input that ends early, and non-zero padding or words after the last
// pixel; so every accepted stream decodes to one image and encodes back to itself.
// Neither function allocates beyond the returned string; DecodeRvl writes only out[0..count).
//
// Thread safety: pure functions.
#ifndef CODEC_RVL_CODEC_H_
#define CODEC_RVL_CODEC_H_

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "absl/status/status.h"

namespace skimap::perception {

// Encodes count pixels (row-major depth, 0 = no measurement).
std::string EncodeRvl(const uint16_t* pixels, size_t count);
// Appends the encoding to *out (reuses its capacity: no allocation once it is large enough).
void EncodeRvlTo(const uint16_t* pixels, size_t count, std::string* out);

// Decodes `bytes` into out[0..count). On error out's content is unspecified.
[[nodiscard]] absl::Status DecodeRvl(std::string_view bytes, uint16_t* out, size_t count);

}  // namespace skimap::perception

#endif  // CODEC_RVL_CODEC_H_
