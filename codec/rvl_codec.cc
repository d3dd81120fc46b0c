#include "codec/rvl_codec.h"

#include <cstring>

#include "absl/strings/str_cat.h"

namespace skimap::perception {
namespace {

// Longest VLE the decoder takes: 10 nibbles (30 bits) cover every run length of an image
// up to 2^30 pixels and every zigzag delta (< 2^17).
constexpr int kMaxVleNibbles = 10;

class NibbleWriter {
 public:
  explicit NibbleWriter(std::string* out) : out_(out) {}
  void Put(uint32_t nibble) {
    word_ = (word_ << 4) | nibble;
    if (++nibbles_ == 8) Flush();
  }
  void Vle(uint32_t value) {
    for (;;) {
      const uint32_t bits = value & 7;
      value >>= 3;
      if (value == 0) {
        Put(bits);
        return;
      }
      Put(bits | 8);
    }
  }
  // Pads the last word with zero nibbles and writes it.
  void Finish() {
    if (nibbles_ == 0) return;
    word_ <<= 4 * (8 - nibbles_);
    Flush();
  }

 private:
  void Flush() {
    const char bytes[4] = {static_cast<char>(word_), static_cast<char>(word_ >> 8),
                           static_cast<char>(word_ >> 16), static_cast<char>(word_ >> 24)};
    out_->append(bytes, 4);
    word_ = 0;
    nibbles_ = 0;
  }
  std::string* out_;
  uint32_t word_ = 0;
  int nibbles_ = 0;
};

class NibbleReader {
 public:
  explicit NibbleReader(std::string_view bytes)
      : p_(reinterpret_cast<const uint8_t*>(bytes.data())), end_(p_ + bytes.size()) {}
  // Reads one VLE value into *value; false when the input ends or the code is too long or
  // not minimal.
  bool Vle(uint32_t* value) {
    uint32_t v = 0;
    for (int shift = 0; shift < 3 * kMaxVleNibbles; shift += 3) {
      if (nibbles_ == 0 && !Load()) return false;
      const uint32_t nibble = word_ >> 28;
      word_ <<= 4;
      --nibbles_;
      v |= (nibble & 7) << shift;
      if ((nibble & 8) == 0) {
        *value = v;
        return nibble != 0 || shift == 0;  // a trailing zero group is not minimal
      }
    }
    return false;
  }
  // True when nothing but zero padding is left.
  bool AtCleanEnd() const { return p_ == end_ && word_ == 0; }

 private:
  bool Load() {
    if (p_ == end_) return false;
    word_ = uint32_t(p_[0]) | uint32_t(p_[1]) << 8 | uint32_t(p_[2]) << 16 | uint32_t(p_[3]) << 24;
    p_ += 4;
    nibbles_ = 8;
    return true;
  }
  const uint8_t* p_;
  const uint8_t* end_;
  uint32_t word_ = 0;
  int nibbles_ = 0;
};

absl::Status Corrupt(const char* what, size_t pixel) {
  return absl::InvalidArgumentError(absl::StrCat("depth: RVL ", what, " at pixel ", pixel));
}

}  // namespace

void EncodeRvlTo(const uint16_t* pixels, size_t count, std::string* out) {
  NibbleWriter w(out);
  int32_t previous = 0;
  size_t i = 0;
  while (i < count) {
    const size_t zeros_begin = i;
    while (i < count && pixels[i] == 0) ++i;
    const size_t values_begin = i;
    while (i < count && pixels[i] != 0) ++i;
    w.Vle(static_cast<uint32_t>(values_begin - zeros_begin));
    w.Vle(static_cast<uint32_t>(i - values_begin));
    for (size_t j = values_begin; j < i; ++j) {
      const int32_t delta = int32_t(pixels[j]) - previous;
      previous = pixels[j];
      w.Vle(static_cast<uint32_t>(delta << 1) ^ static_cast<uint32_t>(delta >> 31));
    }
  }
  w.Finish();
}

std::string EncodeRvl(const uint16_t* pixels, size_t count) {
  std::string out;
  out.reserve(count / 2 + 16);
  EncodeRvlTo(pixels, count, &out);
  return out;
}

absl::Status DecodeRvl(std::string_view bytes, uint16_t* out, size_t count) {
  if (bytes.size() % 4 != 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("depth: RVL stream has ", bytes.size(), " bytes, not a multiple of 4"));
  }
  NibbleReader r(bytes);
  int32_t previous = 0;
  size_t i = 0;
  while (i < count) {
    uint32_t zeros = 0, values = 0;
    if (!r.Vle(&zeros) || !r.Vle(&values)) return Corrupt("stream ends early or bad code", i);
    if (zeros > count - i || values > count - i - zeros) return Corrupt("run past the image", i);
    // Runs are maximal: only the first zero run may be empty, only the last value run.
    if (zeros == 0 && i > 0) return Corrupt("empty zero run", i);
    if (values == 0 && i + zeros != count) return Corrupt("empty value run", i);
    std::memset(out + i, 0, zeros * sizeof(uint16_t));
    i += zeros;
    for (const size_t end = i + values; i < end; ++i) {
      uint32_t code = 0;
      if (!r.Vle(&code)) return Corrupt("stream ends early or bad code", i);
      const int32_t delta = static_cast<int32_t>(code >> 1) ^ -static_cast<int32_t>(code & 1);
      const int32_t value = previous + delta;
      if (value <= 0 || value > 0xffff) return Corrupt("value outside 1..65535", i);
      out[i] = static_cast<uint16_t>(value);
      previous = value;
    }
  }
  if (!r.AtCleanEnd()) {
    return absl::InvalidArgumentError("depth: RVL stream has data after the last pixel");
  }
  return absl::OkStatus();
}

}  // namespace skimap::perception
