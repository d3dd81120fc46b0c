// The PNG layouts datasets and cameras write (non-interlaced 8- or 16-bit grey, 8-bit RGB
// or RGBA), decoded with libdeflate instead of zlib: whole-buffer inflation, 2-4 times
// zlib's speed on our images (docs/measurements/2026-12-03-png-fast-path.md), then the
// rows unfiltered and converted here.
//
// The contract that keeps this small and safe: the fast path gives exactly libpng's
// pixels or declines. It declines (returns false) for every layout or mode it does not
// handle and for anything unusual or damaged — a chunk type that is not four letters, a
// chunk CRC that does not match, a critical chunk it does not know, a PLTE, data that does
// not inflate to exactly the rows, an undefined filter type — and then libpng decodes the bytes as
// before, with its own checks and its own error text. tests/codec/image_files_test.cc compares both
// decoders over every filter type, layout and mode; the image fuzz target compares them on
// arbitrary bytes.
#include <libdeflate.h>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <vector>

#include "codec/image_formats.h"

namespace skimap::perception::image_formats {
namespace {

uint32_t BigEndian32(const unsigned char* p) {
  return (uint32_t{p[0]} << 24) | (uint32_t{p[1]} << 16) | (uint32_t{p[2]} << 8) | p[3];
}

struct Header {
  uint32_t width = 0, height = 0;
  int bit_depth = 0, color_type = 0;
  int channels = 0;  // stored samples per pixel
};

// Paeth's predictor (PNG specification, 9.4).
inline uint8_t Paeth(int a, int b, int c) {
  const int pa = std::abs(b - c), pb = std::abs(a - c), pc = std::abs(a + b - 2 * c);
  if (pa <= pb && pa <= pc) return static_cast<uint8_t>(a);
  return static_cast<uint8_t>(pb <= pc ? b : c);
}

// Filters 1, 3 and 4 (Sub, Average, Paeth) for pixels of kBpp bytes (1-4): the left pixel
// is carried in locals, so that each byte waits for an add on the byte kBpp before it,
// not for that byte's store to come back from memory (1.2-1.3x the byte-at-a-time loops on
// the bench's colour and depth files).
template <int kType, size_t kBpp>
void UnfilterPixels(uint8_t* row, const uint8_t* prev, size_t n) {
  if (n < kBpp) return;
  int left[kBpp], upper_left[kBpp];
  for (size_t k = 0; k < kBpp; ++k) {  // the first pixel: no left neighbour
    const int b = kType == 1 ? 0 : prev[k];
    const int predictor = kType == 3 ? b >> 1 : b;  // Paeth(0, b, 0) is b
    left[k] = (row[k] + predictor) & 0xff;
    row[k] = static_cast<uint8_t>(left[k]);
    upper_left[k] = b;
  }
  for (size_t i = kBpp; i + kBpp <= n; i += kBpp) {
    for (size_t k = 0; k < kBpp; ++k) {
      int predictor;
      if constexpr (kType == 1) {
        predictor = left[k];
      } else if constexpr (kType == 3) {
        predictor = (left[k] + prev[i + k]) >> 1;
      } else {
        const int b = prev[i + k];
        predictor = Paeth(left[k], b, upper_left[k]);
        upper_left[k] = b;
      }
      left[k] = (row[i + k] + predictor) & 0xff;
      row[i + k] = static_cast<uint8_t>(left[k]);
    }
  }
}

#if defined(__SSE2__)
// Paeth for 3- and 4-byte pixels, a pixel's channels at once in 16-bit lanes (SSE2 is
// part of x86-64): the same arithmetic and ties as UnfilterPixels<4, kBpp>, whose byte-wise
// branches the colour images' Paeth rows mispredicted (4.5 % of skimapd's CPU while
// streaming PNG folders). Reads 4 bytes at a pixel, so the last pixel of a row of 3-byte
// pixels is done byte by byte. (Average the same way was slower than UnfilterPixels: its
// byte loop has no branch to mispredict.)
template <size_t kBpp>
void UnfilterPaethSse2(uint8_t* row, const uint8_t* prev, size_t n) {
  static_assert(kBpp == 3 || kBpp == 4);
  if (n < 2 * kBpp) return UnfilterPixels<4, kBpp>(row, prev, n);
  const __m128i zero = _mm_setzero_si128();
  auto load = [&](const uint8_t* p) {
    uint32_t w;
    std::memcpy(&w, p, 4);
    return _mm_unpacklo_epi8(_mm_cvtsi32_si128(static_cast<int>(w)), zero);
  };
  auto abs16 = [](__m128i v) { return _mm_max_epi16(v, _mm_sub_epi16(_mm_setzero_si128(), v)); };
  // The first pixel: no left neighbour (Paeth(0, b, 0) is b).
  for (size_t k = 0; k < kBpp; ++k) row[k] = static_cast<uint8_t>(row[k] + prev[k]);
  __m128i a = load(row), c = load(prev);
  const __m128i low_byte = _mm_set1_epi16(0xff);
  size_t i = kBpp;
  for (; i + 4 <= n; i += kBpp) {
    const __m128i b = load(prev + i), x = load(row + i);
    const __m128i bc = _mm_sub_epi16(b, c), ac = _mm_sub_epi16(a, c);
    const __m128i pa = abs16(bc), pb = abs16(ac), pc = abs16(_mm_add_epi16(bc, ac));
    // a when pa <= pb and pa <= pc, else b when pb <= pc, else c.
    const __m128i not_a = _mm_or_si128(_mm_cmpgt_epi16(pa, pb), _mm_cmpgt_epi16(pa, pc));
    const __m128i not_b = _mm_cmpgt_epi16(pb, pc);
    const __m128i b_or_c = _mm_or_si128(_mm_and_si128(not_b, c), _mm_andnot_si128(not_b, b));
    const __m128i predictor =
        _mm_or_si128(_mm_and_si128(not_a, b_or_c), _mm_andnot_si128(not_a, a));
    c = b;
    a = _mm_and_si128(_mm_add_epi16(x, predictor), low_byte);
    const uint32_t w = static_cast<uint32_t>(_mm_cvtsi128_si32(_mm_packus_epi16(a, zero)));
    std::memcpy(row + i, &w, kBpp);
  }
  // The rest (at most one pixel), byte by byte from the vector's left and upper-left.
  for (; i + kBpp <= n; i += kBpp) {
    for (size_t k = 0; k < kBpp; ++k) {
      const int left = row[i - kBpp + k], b = prev[i + k], upper_left = prev[i - kBpp + k];
      row[i + k] = static_cast<uint8_t>(row[i + k] + Paeth(left, b, upper_left));
    }
  }
}
#endif

// Undoes row filter `type` on `row` (n bytes, bpp bytes per pixel) against `prev` (the
// previous row unfiltered, all zero above the first). False for a filter type PNG does not
// define. REQUIRES: bpp in 1..4 (every layout the fast path takes), n a multiple of bpp.
bool Unfilter(int type, uint8_t* row, const uint8_t* prev, size_t n, size_t bpp) {
  using Fn = void (*)(uint8_t*, const uint8_t*, size_t);
  static constexpr Fn kPixels[3][4] = {
    {UnfilterPixels<1, 1>, UnfilterPixels<1, 2>, UnfilterPixels<1, 3>, UnfilterPixels<1, 4>},
    {UnfilterPixels<3, 1>, UnfilterPixels<3, 2>, UnfilterPixels<3, 3>, UnfilterPixels<3, 4>},
#if defined(__SSE2__)
    {UnfilterPixels<4, 1>, UnfilterPixels<4, 2>, UnfilterPaethSse2<3>, UnfilterPaethSse2<4>}
  };
#else
    {UnfilterPixels<4, 1>, UnfilterPixels<4, 2>, UnfilterPixels<4, 3>, UnfilterPixels<4, 4>}
  };
#endif
  switch (type) {
    case 0:
      return true;
    case 2:
      for (size_t i = 0; i < n; ++i) row[i] = static_cast<uint8_t>(row[i] + prev[i]);
      return true;
    case 1:
    case 3:
    case 4:
      kPixels[type == 1 ? 0 : type == 3 ? 1 : 2][bpp - 1](row, prev, n);
      return true;
    default:
      return false;
  }
}

// The pixel type the fast path gives for `h` in `mode`, as libpng's transforms in
// png_image.cc would: -1 when it declines (CV_8UC1 is 0).
int OutputType(const Header& h, ImageMode mode) {
  if (h.color_type == 0) {  // grey, 8 or 16 bit
    const bool keep_depth = mode == ImageMode::kUnchanged || mode == ImageMode::kAnyDepth;
    const int depth = h.bit_depth == 16 && keep_depth ? CV_16U : CV_8U;
    const bool colour_out = mode == ImageMode::kColor || mode == ImageMode::kRgb;
    return CV_MAKETYPE(depth, colour_out ? 3 : 1);
  }
  if (h.bit_depth != 8) return -1;
  // RGB / RGBA, 8 bit: grey conversion (libpng's own weights and rounding) is libpng's.
  if (mode == ImageMode::kColor || mode == ImageMode::kRgb) return CV_8UC3;
  if (mode == ImageMode::kUnchanged) return CV_8UC(h.channels);
  return -1;
}

// Writes one unfiltered row (stored layout) to `out` in the output layout.
void ConvertRow(const uint8_t* in, const Header& h, ImageMode mode, int out_type, uint8_t* out) {
  const size_t w = h.width;
  if (h.color_type == 0) {
    const int out_channels = CV_MAT_CN(out_type);
    if (CV_MAT_DEPTH(out_type) == CV_16U) {  // as stored, in host (little-endian) order
      for (size_t i = 0; i < w; ++i) {
        const uint16_t v = static_cast<uint16_t>((in[2 * i] << 8) | in[2 * i + 1]);
        std::memcpy(out + 2 * i, &v, 2);
      }
      return;
    }
    const size_t step = h.bit_depth == 16 ? 2 : 1;  // 16 -> 8 bit: the high byte
    if (out_channels == 1) {
      if (step == 1) {
        std::memcpy(out, in, w);
      } else {
        for (size_t i = 0; i < w; ++i) out[i] = in[2 * i];
      }
    } else {
      for (size_t i = 0; i < w; ++i) out[3 * i] = out[3 * i + 1] = out[3 * i + 2] = in[step * i];
    }
    return;
  }
  const size_t c = static_cast<size_t>(h.channels);
  const bool bgr = mode != ImageMode::kRgb;
  const int out_channels = CV_MAT_CN(out_type);
  if (!bgr && out_channels == 3 && c == 3) {
    std::memcpy(out, in, 3 * w);
    return;
  }
  for (size_t i = 0; i < w; ++i) {
    const uint8_t* p = in + c * i;
    uint8_t* o = out + out_channels * i;
    o[0] = bgr ? p[2] : p[0];
    o[1] = p[1];
    o[2] = bgr ? p[0] : p[2];
    if (out_channels == 4) o[3] = p[3];
  }
}

struct DecompressorDeleter {
  void operator()(libdeflate_decompressor* d) const { libdeflate_free_decompressor(d); }
};

}  // namespace

bool DecodePngFast(std::string_view bytes, ImageMode mode, cv::Mat* out) {
  static constexpr unsigned char kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  const auto* data = reinterpret_cast<const unsigned char*>(bytes.data());
  const size_t size = bytes.size();
  if (size < 8 || std::memcmp(data, kSignature, 8) != 0) return false;
  // The chunks: IHDR first, then the consecutive IDATs; ancillary chunks skipped (libpng
  // applies none of them in png_image.cc's transforms).
  Header h;
  thread_local std::vector<unsigned char> idat;
  idat.clear();
  bool have_header = false, in_idat = false, idat_done = false;
  for (size_t at = 8;;) {
    if (size - at < 12) break;  // the end (with or without IEND)
    const uint32_t length = BigEndian32(data + at);
    if (length > 0x7fffffffu || length > size - at - 12) return false;
    const unsigned char* type = data + at + 4;
    const unsigned char* body = type + 4;
    for (int k = 0; k < 4; ++k) {  // a chunk type is four ASCII letters
      if (!((type[k] >= 'A' && type[k] <= 'Z') || (type[k] >= 'a' && type[k] <= 'z'))) {
        return false;
      }
    }
    const bool critical = (type[0] & 0x20) == 0;
    const bool is_ihdr = std::memcmp(type, "IHDR", 4) == 0;
    const bool is_idat = std::memcmp(type, "IDAT", 4) == 0;
    const bool is_iend = std::memcmp(type, "IEND", 4) == 0;
    if (critical && !is_ihdr && !is_idat && !is_iend) return false;  // PLTE or unknown
    // Every chunk's CRC, ancillary ones too (libpng may warn or refuse: not ours to judge).
    if (libdeflate_crc32(0, type, length + 4) != BigEndian32(body + length)) {
      return false;
    }
    if (is_ihdr != !have_header) return false;  // IHDR first, once
    if (is_ihdr) {
      if (length != 13) return false;
      h.width = BigEndian32(body);
      h.height = BigEndian32(body + 4);
      h.bit_depth = body[8];
      h.color_type = body[9];
      // compression 0, filter method 0, no interlace; libpng's user limits (2^20).
      if (body[10] != 0 || body[11] != 0 || body[12] != 0) return false;
      if (h.width == 0 || h.height == 0 || h.width > (1u << 20) || h.height > (1u << 20)) {
        return false;
      }
      if (h.color_type == 0 && (h.bit_depth == 8 || h.bit_depth == 16)) {
        h.channels = 1;
      } else if ((h.color_type == 2 || h.color_type == 6) && h.bit_depth == 8) {
        h.channels = h.color_type == 2 ? 3 : 4;
      } else {
        return false;
      }
      have_header = true;
    } else if (is_idat) {
      if (idat_done) return false;  // IDATs not consecutive: libpng's to judge
      in_idat = true;
      idat.insert(idat.end(), body, body + length);
    } else {
      if (in_idat) idat_done = true;
      if (is_iend) break;
    }
    at += 12 + size_t{length};
  }
  if (!have_header || idat.empty()) return false;
  const int out_type = OutputType(h, mode);
  if (out_type < 0 || !CheckPixels("PNG", h.width, h.height).ok()) return false;
  const size_t bpp = static_cast<size_t>(h.channels) * (h.bit_depth / 8);
  const size_t row_bytes = bpp * h.width;
  const size_t stride = row_bytes + 1;  // the filter type byte first
  thread_local std::vector<unsigned char> rows;
  rows.resize(stride * h.height);
  thread_local std::unique_ptr<libdeflate_decompressor, DecompressorDeleter> decompressor(
      libdeflate_alloc_decompressor());
  if (decompressor == nullptr) return false;
  // Exactly the rows, or decline (libpng reports what is wrong).
  if (libdeflate_zlib_decompress(decompressor.get(), idat.data(), idat.size(), rows.data(),
                                 rows.size(), nullptr) != LIBDEFLATE_SUCCESS) {
    return false;
  }
  out->create(static_cast<int>(h.height), static_cast<int>(h.width), out_type);
  thread_local std::vector<unsigned char> zeros;
  zeros.assign(row_bytes, 0);
  const unsigned char* prev = zeros.data();
  for (uint32_t r = 0; r < h.height; ++r) {
    unsigned char* row = rows.data() + stride * r;
    if (!Unfilter(row[0], row + 1, prev, row_bytes, bpp)) return false;
    ConvertRow(row + 1, h, mode, out_type, out->ptr(static_cast<int>(r)));
    prev = row + 1;
  }
  return true;
}

}  // namespace skimap::perception::image_formats
