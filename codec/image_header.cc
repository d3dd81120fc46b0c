#include "codec/image_header.h"

#include "absl/strings/str_cat.h"

namespace skimap::perception {
namespace {

uint32_t Be16(const uint8_t* p) { return uint32_t(p[0]) << 8 | p[1]; }
uint32_t Be32(const uint8_t* p) { return Be16(p) << 16 | Be16(p + 2); }

absl::Status Bad(absl::string_view what, absl::string_view format, absl::string_view why) {
  return absl::InvalidArgumentError(absl::StrCat(what, ": not a ", format, " (", why, ")"));
}

absl::StatusOr<ImageHeader> ReadPng(const uint8_t* b, size_t n, absl::string_view what) {
  // Signature (8), IHDR length (4) and type (4), then the 13 bytes of IHDR.
  constexpr uint8_t kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (n < 8 + 8 + 13) return Bad(what, "PNG", "shorter than its header");
  for (int i = 0; i < 8; ++i) {
    if (b[i] != kSignature[i]) return Bad(what, "PNG", "bad signature");
  }
  if (Be32(b + 8) != 13 || absl::string_view(reinterpret_cast<const char*>(b + 12), 4) != "IHDR") {
    return Bad(what, "PNG", "first chunk is not IHDR");
  }
  ImageHeader h;
  h.width = Be32(b + 16);
  h.height = Be32(b + 20);
  h.bit_depth = b[24];
  switch (b[25]) {  // colour type
    case 0:         // greyscale
    case 3:         // palette
      h.channels = 1;
      break;
    case 2:
      h.channels = 3;
      break;
    case 4:
      h.channels = 2;
      break;
    case 6:
      h.channels = 4;
      break;
    default:
      return Bad(what, "PNG", absl::StrCat("colour type ", b[25]));
  }
  return h;
}

absl::StatusOr<ImageHeader> ReadJpeg(const uint8_t* b, size_t n, absl::string_view what) {
  if (n < 4 || b[0] != 0xff || b[1] != 0xd8) return Bad(what, "JPEG", "no SOI marker");
  if (b[n - 2] != 0xff || b[n - 1] != 0xd9) {
    return Bad(what, "JPEG", "no EOI marker at the end: truncated");
  }
  size_t pos = 2;
  while (pos + 4 <= n) {
    if (b[pos] != 0xff) return Bad(what, "JPEG", "marker expected");
    const uint8_t marker = b[pos + 1];
    if (marker == 0xff) {  // fill byte
      ++pos;
      continue;
    }
    if ((marker >= 0xd0 && marker <= 0xd7) || marker == 0x01) {  // no payload
      pos += 2;
      continue;
    }
    if (marker == 0xd9 || marker == 0xda) return Bad(what, "JPEG", "no frame header");
    const size_t length = Be16(b + pos + 2);  // includes its own two bytes
    if (length < 2 || pos + 2 + length > n) return Bad(what, "JPEG", "segment cut short");
    const bool sof =
        marker >= 0xc0 && marker <= 0xcf && marker != 0xc4 && marker != 0xc8 && marker != 0xcc;
    if (sof) {
      if (length < 8) return Bad(what, "JPEG", "frame header cut short");
      const uint8_t* s = b + pos + 4;
      ImageHeader h;
      h.bit_depth = s[0];
      h.height = Be16(s + 1);
      h.width = Be16(s + 3);
      h.channels = s[5];
      return h;
    }
    pos += 2 + length;
  }
  return Bad(what, "JPEG", "no frame header");
}

}  // namespace

absl::StatusOr<ImageHeader> ReadImageHeader(ImageFormat format, absl::string_view bytes,
                                            absl::string_view what) {
  const auto* b = reinterpret_cast<const uint8_t*>(bytes.data());
  return format == ImageFormat::kPng ? ReadPng(b, bytes.size(), what)
                                     : ReadJpeg(b, bytes.size(), what);
}

}  // namespace skimap::perception
