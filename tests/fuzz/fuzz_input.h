// Helpers shared by the libFuzzer targets (tests/fuzz/*_fuzz.cc) and the seed writer
// (make_seeds.cc): a reader for the few control values at the front of an input, and
// checksum fix-ups so that mutated inputs get past the CRCs into the parsers behind them.
//
// Input layout of every target: control bytes first (read with FuzzInput), then the bytes
// under test (Rest()). Reads past the end give zeros, so every input is a valid one.
//
// Thread safety: single-threaded values and pure functions.
#ifndef TESTS_FUZZ_FUZZ_INPUT_H_
#define TESTS_FUZZ_FUZZ_INPUT_H_

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>

#include "base/encoding.h"

namespace skimap::fuzz {

class FuzzInput {
 public:
  FuzzInput(const uint8_t* data, size_t size) : in_(reinterpret_cast<const char*>(data), size) {}
  uint8_t U8() {
    if (pos_ >= in_.size()) return 0;
    return static_cast<uint8_t>(in_[pos_++]);
  }
  uint16_t U16() { return static_cast<uint16_t>(U8() | U8() << 8); }
  uint32_t U32() { return uint32_t{U16()} | uint32_t{U16()} << 16; }
  // A u16 length, then that many bytes (fewer at the end of the input).
  std::string_view Bytes() {
    const size_t n = std::min<size_t>(U16(), in_.size() - pos_);
    std::string_view out = in_.substr(pos_, n);
    pos_ += n;
    return out;
  }
  // Everything not read yet.
  std::string_view Rest() {
    std::string_view out = in_.substr(pos_);
    pos_ = in_.size();
    return out;
  }

 private:
  std::string_view in_;
  size_t pos_ = 0;
};

// Appends what FuzzInput::Bytes reads back (for the seed writer).
inline void PutBytes(std::string* out, std::string_view b) {
  Encoder e(out);
  e.U8(static_cast<uint8_t>(b.size()));
  e.U8(static_cast<uint8_t>(b.size() >> 8));
  e.Bytes(b.substr(0, 0xffff));
}

// Replaces the last 4 bytes with the CRC-32C of the bytes before them: the trailer of the
// SkiMap volume file, chunk blobs and forest blobs. No-op below 4 bytes.
inline void FixTrailingCrc(std::string* bytes) {
  if (bytes->size() < 4) return;
  const uint32_t crc = Crc32c(std::string_view(*bytes).substr(0, bytes->size() - 4));
  for (int i = 0; i < 4; ++i) (*bytes)[bytes->size() - 4 + i] = static_cast<char>(crc >> (8 * i));
}

// Crashes the target with a message: a broken invariant that no input may cause.
[[noreturn]] inline void Fail(const char* what) {
  std::fprintf(stderr, "fuzz invariant broken: %s\n", what);
  std::abort();
}

}  // namespace skimap::fuzz

#endif  // TESTS_FUZZ_FUZZ_INPUT_H_
