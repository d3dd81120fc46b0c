// The token file of skimapd --auth_tokens_file: one bearer token per line.
//
//   # comment lines and blank lines are ignored
//   <token> <role> [<map>,<map>,...]
//   4f0c8e1d2b7a9c3e5f6a7b8c9d0e1f2a  admin
//   robot-7-0a9b8c7d6e5f4a3b2c1d       write  kitchen,hall
//   viewer-1a2b3c4d5e6f7a8b9c0d        read   *
//
// Fields are separated by spaces or tabs. <token>: 16 to 256 printable ASCII characters
// without spaces (what a client sends as `authorization: Bearer <token>`). <role>: read,
// write or admin. The optional third field limits the token to those map ids ("*" or
// nothing: every map). A token may appear once. A token is named "line N" in messages and
// logs; the token itself never appears in any message.
//
// Thread safety: pure functions.
#ifndef SERVER_CORE_AUTH_TOKEN_FILE_H_
#define SERVER_CORE_AUTH_TOKEN_FILE_H_

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "server/core/auth/grant.h"

namespace skimap::server::auth {

inline constexpr size_t kMinTokenLength = 16;
inline constexpr size_t kMaxTokenLength = 256;

using TokenDigest = std::array<uint8_t, 32>;  // SHA-256

// SHA-256 of `token` (libcrypto).
TokenDigest DigestToken(absl::string_view token);

struct TokenEntry {
  TokenDigest digest;  // the token is kept only as its digest
  Grant grant;         // grant.label = "line N"
};

// Parses the text of a token file. InvalidArgument "line N: ..." naming the field at fault
// (never echoing a token) for a malformed line, a short or long token, an unknown role or a
// token given twice; InvalidArgument if the file has no token at all.
absl::StatusOr<std::vector<TokenEntry>> ParseTokenFile(absl::string_view text);

// Reads and parses the file at `path`. NotFound / PermissionDenied naming the path if it
// cannot be read; otherwise as ParseTokenFile, the message prefixed with the path.
absl::StatusOr<std::vector<TokenEntry>> ReadTokenFile(const std::string& path);

}  // namespace skimap::server::auth

#endif  // SERVER_CORE_AUTH_TOKEN_FILE_H_
