#include "server/core/common/page_token.h"

#include "absl/strings/escaping.h"
#include "absl/strings/str_cat.h"
#include "base/encoding.h"

namespace skimap::server {
namespace {

constexpr uint8_t kVersion = 1;

absl::Status Refused(const char* why) {
  return absl::InvalidArgumentError(
      absl::StrCat("page_token: ", why, "; pass the next_page_token of the same query"));
}

}  // namespace

uint32_t QueryFingerprint(uint64_t incarnation, const std::string& rpc,
                          const std::string& filters) {
  std::string bytes;
  Encoder e(&bytes);
  e.U64(incarnation);
  e.U32(static_cast<uint32_t>(rpc.size()));
  e.Bytes(rpc);
  e.Bytes(filters);
  return Crc32c(bytes);
}

std::string EncodePageToken(uint32_t query, const std::string& position) {
  std::string raw;
  Encoder e(&raw);
  e.U8(kVersion);
  e.U32(query);
  e.Bytes(position);
  e.U32(Crc32c(raw));
  return absl::WebSafeBase64Escape(raw);
}

absl::StatusOr<std::string> DecodePageToken(const std::string& token, uint32_t query) {
  std::string raw;
  if (!absl::WebSafeBase64Unescape(token, &raw) || raw.size() < 1 + 4 + 4) {
    return Refused("malformed token");
  }
  // Strict: the one encoding EncodePageToken writes. A last character with other unused
  // bits (or padding) decodes to the same bytes and would pass the CRC otherwise.
  if (absl::WebSafeBase64Escape(raw) != token) return Refused("malformed token");
  const std::string_view body(raw.data(), raw.size() - 4);
  Decoder crc_in(std::string_view(raw).substr(raw.size() - 4));
  uint32_t crc = 0;
  if (!crc_in.U32(&crc) || crc != Crc32c(body)) return Refused("corrupted or truncated token");
  Decoder d(body);
  uint8_t version = 0;
  uint32_t issued_for = 0;
  if (!d.U8(&version) || version != kVersion) return Refused("unknown token version");
  if (!d.U32(&issued_for) || issued_for != query) {
    return Refused("token was issued for another map or query");
  }
  return std::string(body.substr(1 + 4));
}

}  // namespace skimap::server
