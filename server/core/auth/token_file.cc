#include "server/core/auth/token_file.h"

#include <openssl/crypto.h>
#include <openssl/evp.h>

#include <fstream>
#include <sstream>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "base/echo.h"

namespace skimap::server::auth {

TokenDigest DigestToken(absl::string_view token) {
  TokenDigest digest{};
  unsigned int size = 0;
  EVP_Digest(token.data(), token.size(), digest.data(), &size, EVP_sha256(), nullptr);
  return digest;
}

absl::StatusOr<std::vector<TokenEntry>> ParseTokenFile(absl::string_view text) {
  std::vector<TokenEntry> entries;
  int line_number = 0;
  for (absl::string_view line : absl::StrSplit(text, '\n')) {
    ++line_number;
    const absl::string_view stripped = absl::StripAsciiWhitespace(line);
    if (stripped.empty() || stripped.front() == '#') continue;
    const std::vector<absl::string_view> fields =
        absl::StrSplit(stripped, absl::ByAnyChar(" \t"), absl::SkipEmpty());
    const std::string where = absl::StrCat("line ", line_number);
    if (fields.size() < 2 || fields.size() > 3) {
      return absl::InvalidArgumentError(absl::StrCat(
          where, ": expected <token> <role> [<map>,...], found ", fields.size(), " fields"));
    }
    const absl::string_view token = fields[0];
    if (token.size() < kMinTokenLength || token.size() > kMaxTokenLength) {
      return absl::InvalidArgumentError(absl::StrCat(where, ": the token must have ",
                                                     kMinTokenLength, " to ", kMaxTokenLength,
                                                     " characters, it has ", token.size()));
    }
    for (char c : token) {
      if (c < 0x21 || c > 0x7e) {
        return absl::InvalidArgumentError(
            absl::StrCat(where, ": the token holds a character that is not printable ASCII"));
      }
    }
    TokenEntry entry{.digest = DigestToken(token)};
    entry.grant.label = where;
    if (!ParseRole(fields[1], &entry.grant.role)) {
      return absl::InvalidArgumentError(
          absl::StrCat(where, ": role ", Echo(fields[1]), " is not one of read, write, admin"));
    }
    if (fields.size() == 3 && fields[2] != "*") {
      for (absl::string_view map : absl::StrSplit(fields[2], ',')) {
        if (map.empty() || map == "*" || map.find('/') != absl::string_view::npos) {
          return absl::InvalidArgumentError(absl::StrCat(where, ": map scope ", Echo(fields[2]),
                                                         " is not a comma list of map ids"));
        }
        entry.grant.maps.emplace_back(map);
      }
    }
    for (const TokenEntry& other : entries) {
      if (CRYPTO_memcmp(other.digest.data(), entry.digest.data(), entry.digest.size()) == 0) {
        return absl::InvalidArgumentError(
            absl::StrCat(where, ": the same token as ", other.grant.label));
      }
    }
    entries.push_back(std::move(entry));
  }
  if (entries.empty()) return absl::InvalidArgumentError("no token in the file");
  return entries;
}

absl::StatusOr<std::vector<TokenEntry>> ReadTokenFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    return absl::NotFoundError(absl::StrCat("--auth_tokens_file ", path, ": cannot be read"));
  }
  std::ostringstream text;
  text << in.rdbuf();
  absl::StatusOr<std::vector<TokenEntry>> entries = ParseTokenFile(text.str());
  if (!entries.ok()) {
    return absl::Status(entries.status().code(), absl::StrCat("--auth_tokens_file ", path, ": ",
                                                              entries.status().message()));
  }
  return entries;
}

}  // namespace skimap::server::auth
