#include "server/core/auth/authorizer.h"

#include <openssl/crypto.h>

#include <utility>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"

namespace skimap::server::auth {

absl::StatusOr<std::unique_ptr<Authorizer>> Authorizer::Open(const std::string& path) {
  absl::StatusOr<Tokens> tokens = ReadTokenFile(path);
  if (!tokens.ok()) return tokens.status();
  return std::unique_ptr<Authorizer>(new Authorizer(path, *std::move(tokens)));
}

Authorizer::Authorizer(std::string path, Tokens tokens)
    : path_(std::move(path)), tokens_(std::make_shared<const Tokens>(std::move(tokens))) {}

absl::Status Authorizer::Reload() {
  absl::StatusOr<Tokens> tokens = ReadTokenFile(path_);
  if (!tokens.ok()) return tokens.status();
  auto fresh = std::make_shared<const Tokens>(*std::move(tokens));
  MutexLock lock(&mu_);
  tokens_ = std::move(fresh);
  return absl::OkStatus();
}

std::shared_ptr<const Authorizer::Tokens> Authorizer::tokens() const {
  MutexLock lock(&mu_);
  return tokens_;
}

size_t Authorizer::size() const { return tokens()->size(); }

absl::StatusOr<Grant> Authorizer::Authenticate(absl::string_view authorization) const {
  authorization = absl::StripAsciiWhitespace(authorization);
  if (authorization.empty()) {
    return absl::UnauthenticatedError(
        "missing bearer token (send the header `authorization: Bearer <token>`)");
  }
  constexpr absl::string_view kScheme = "bearer ";
  if (authorization.size() <= kScheme.size() ||
      !absl::EqualsIgnoreCase(authorization.substr(0, kScheme.size()), kScheme)) {
    return absl::UnauthenticatedError("malformed authorization header (expected `Bearer <token>`)");
  }
  const absl::string_view token =
      absl::StripLeadingAsciiWhitespace(authorization.substr(kScheme.size()));
  const TokenDigest digest = DigestToken(token);
  const std::shared_ptr<const Tokens> tokens = this->tokens();
  const TokenEntry* match = nullptr;
  for (const TokenEntry& entry : *tokens) {  // every entry, whatever matched before
    const bool equal = CRYPTO_memcmp(entry.digest.data(), digest.data(), digest.size()) == 0;
    if (equal) match = &entry;
  }
  if (match == nullptr) return absl::UnauthenticatedError("unknown bearer token");
  return match->grant;
}

absl::StatusOr<Grant> Authorizer::Authorize(absl::string_view authorization, Role needed) const {
  absl::StatusOr<Grant> grant = Authenticate(authorization);
  if (!grant.ok()) return grant.status();
  if (absl::Status s = grant->Check(needed); !s.ok()) return s;
  return grant;
}

absl::StatusOr<Grant> Authorizer::AuthorizeMap(absl::string_view authorization, Role needed,
                                               absl::string_view resource) const {
  absl::StatusOr<Grant> grant = Authenticate(authorization);
  if (!grant.ok()) return grant.status();
  if (absl::Status s = grant->CheckMap(needed, resource); !s.ok()) return s;
  return grant;
}

}  // namespace skimap::server::auth
