// Page tokens decode strictly: the one encoding EncodePageToken writes.
#include "server/core/common/page_token.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>

#include "absl/strings/escaping.h"

namespace skimap::server {
namespace {

TEST(PageTokenTest, RoundTripsAndRefusesAnotherQuery) {
  const uint32_t query = QueryFingerprint(7, "GetVoxels", "box");
  const std::string token = EncodePageToken(query, "pos");
  absl::StatusOr<std::string> position = DecodePageToken(token, query);
  ASSERT_TRUE(position.ok()) << position.status();
  EXPECT_EQ(*position, "pos");
  EXPECT_EQ(DecodePageToken(token, query + 1).status().code(), absl::StatusCode::kInvalidArgument);
}

// A last base64 character that differs only in its unused bits decodes to the same bytes
// (and the same CRC): every such spelling is refused, as is padding.
TEST(PageTokenTest, RefusesNonCanonicalSpellingsOfTheSameBytes) {
  const uint32_t query = QueryFingerprint(1, "GetVoxels", "");
  // 1 + 4 + 1 + 4 = 10 bytes: the last of 14 characters carries 4 unused bits.
  const std::string token = EncodePageToken(query, "x");
  ASSERT_EQ(token.size(), 14u);
  std::string raw;
  ASSERT_TRUE(absl::WebSafeBase64Unescape(token, &raw));
  const std::string alphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789-_";
  int aliases = 0;
  for (char c : alphabet) {
    std::string other = token;
    other.back() = c;
    std::string bytes;
    if (other == token || !absl::WebSafeBase64Unescape(other, &bytes) || bytes != raw) continue;
    ++aliases;
    absl::StatusOr<std::string> decoded = DecodePageToken(other, query);
    EXPECT_EQ(decoded.status().code(), absl::StatusCode::kInvalidArgument) << other;
    EXPECT_THAT(decoded.status().message(), ::testing::HasSubstr("page_token"));
  }
  EXPECT_EQ(aliases, 15);  // 2^4 spellings of the last character, less the canonical one
  EXPECT_FALSE(DecodePageToken(token + "==", query).ok());
}

}  // namespace
}  // namespace skimap::server
