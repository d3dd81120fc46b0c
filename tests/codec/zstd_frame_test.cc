// codec/zstd_frame.h: frames round-trip at every size; a frame that claims another
// size, no size, or that is cut short is refused with a message and writes nothing past
// the buffer.
#include "codec/zstd_frame.h"

#include <gtest/gtest.h>

#include <string>

namespace skimap::perception {
namespace {

TEST(ZstdFrameTest, RoundTripsAndDeclaresItsSize) {
  for (const size_t n : {size_t{0}, size_t{1}, size_t{1000}, size_t{1} << 20}) {
    std::string raw(n, '\0');
    for (size_t i = 0; i < n; ++i) raw[i] = static_cast<char>((i * 7919) >> 5);
    absl::StatusOr<std::string> packed = ZstdCompress(raw);
    ASSERT_TRUE(packed.ok()) << packed.status();
    EXPECT_TRUE(ZstdCheckFrame(*packed, n).ok());
    std::string out(n, 'x');
    ASSERT_TRUE(ZstdDecompressExact(*packed, out.data(), n).ok()) << n;
    EXPECT_EQ(out, raw);
  }
}

TEST(ZstdFrameTest, WrongClaimsAndDamageAreRefused) {
  const std::string raw(5000, 'a');
  const std::string packed = *ZstdCompress(raw, 3);
  absl::Status s = ZstdCheckFrame(packed, 4999);
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("holds 5000 bytes, expected 4999"), std::string::npos) << s;
  s = ZstdCheckFrame("not zstd at all", 15);
  EXPECT_NE(s.message().find("not a zstd frame"), std::string::npos) << s;
  // A buffer of the claimed size, a canary after it: a short or damaged frame is refused.
  std::string out(5000 + 8, 'c');
  EXPECT_FALSE(ZstdDecompressExact(packed.substr(0, packed.size() - 3), out.data(), 5000).ok());
  std::string damaged = packed;
  damaged[damaged.size() / 2] ^= 0x5a;
  (void)ZstdDecompressExact(damaged, out.data(), 5000);  // refused or not: never past 5000
  EXPECT_EQ(out.substr(5000), std::string(8, 'c'));
  EXPECT_FALSE(ZstdDecompressExact(packed, out.data(), 4000).ok());
}

}  // namespace
}  // namespace skimap::perception
