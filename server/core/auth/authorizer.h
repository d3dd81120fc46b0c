// Authorizer: the one place skimapd decides who a caller is. It holds the tokens of the
// token file (token_file.h) as SHA-256 digests and turns an `Authorization` header
// (gRPC metadata `authorization`, HTTP header Authorization) into the caller's Grant.
// Both adapters ask it, then check the grant against the role their call needs
// (docs/operations.md, "Authentication": the table of calls and roles).
//
//   absl::StatusOr<std::unique_ptr<Authorizer>> auth = Authorizer::Open("/etc/skimap/tokens");
//   absl::StatusOr<Grant> grant = (*auth)->Authenticate("Bearer robot-7-0a9b8c7d6e5f4a3b2c1d");
//   (*auth)->AuthorizeMap(header, Role::kWrite, "maps/kitchen");   // both steps at once
//   (*auth)->Reload();   // SIGHUP: the file again; on error the previous tokens stay
//
// The presented token is hashed and compared with every digest with CRYPTO_memcmp, all of
// them each time: the time taken does not depend on how much of a token matched, nor on
// which entry matched. No message and no log line holds a token.
//
// Thread safety: thread safe; Reload may run while calls are authenticated (they see the
// old or the new tokens, never a mix).
#ifndef SERVER_CORE_AUTH_AUTHORIZER_H_
#define SERVER_CORE_AUTH_AUTHORIZER_H_

#include <memory>
#include <string>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "base/mutex.h"
#include "server/core/auth/grant.h"
#include "server/core/auth/token_file.h"

namespace skimap::server::auth {

class Authorizer {
 public:
  // Reads the token file at `path`; its error (ReadTokenFile) if it cannot be used.
  static absl::StatusOr<std::unique_ptr<Authorizer>> Open(const std::string& path);

  // Reads the file again. OK: the new tokens replace the old ones for every later call.
  // An error (the file's, naming the line, never a token) leaves the old tokens in place.
  [[nodiscard]] absl::Status Reload();

  // The grant of the token in `authorization` ("Bearer <token>", the scheme in any case).
  // Unauthenticated "missing bearer token" for an empty header, "malformed Authorization
  // header" for another scheme, "unknown bearer token" for a token not in the file.
  absl::StatusOr<Grant> Authenticate(absl::string_view authorization) const;

  // Authenticate, then Grant::Check(needed): Unauthenticated or PermissionDenied.
  absl::StatusOr<Grant> Authorize(absl::string_view authorization, Role needed) const;
  // Authenticate, then Grant::CheckMap(needed, resource), for a call about one map.
  absl::StatusOr<Grant> AuthorizeMap(absl::string_view authorization, Role needed,
                                     absl::string_view resource) const;

  // Tokens currently loaded.
  size_t size() const;
  const std::string& path() const { return path_; }

 private:
  using Tokens = std::vector<TokenEntry>;
  Authorizer(std::string path, Tokens tokens);
  std::shared_ptr<const Tokens> tokens() const;

  const std::string path_;
  mutable Mutex mu_;
  std::shared_ptr<const Tokens> tokens_ ABSL_GUARDED_BY(mu_);
};

}  // namespace skimap::server::auth

#endif  // SERVER_CORE_AUTH_AUTHORIZER_H_
