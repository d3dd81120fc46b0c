#include "server/auth/tls_files.h"

#include <fstream>
#include <sstream>
#include <tuple>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"

namespace skimap::server::auth {
namespace {

absl::StatusOr<std::string> ReadPem(const std::string& path, const char* flag) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return absl::NotFoundError(absl::StrCat(flag, " ", path, ": cannot be read"));
  std::ostringstream text;
  text << in.rdbuf();
  if (!absl::StrContains(text.str(), "-----BEGIN ")) {
    return absl::InvalidArgumentError(absl::StrCat(flag, " ", path, ": not a PEM file"));
  }
  return text.str();
}

}  // namespace

absl::StatusOr<TlsFiles::Pem> TlsFiles::Read() const {
  if (cert.empty() != key.empty()) {
    return absl::InvalidArgumentError("--tls_cert and --tls_key go together: give both or none");
  }
  if (!client_ca.empty() && cert.empty()) {
    return absl::InvalidArgumentError("--tls_client_ca needs --tls_cert and --tls_key");
  }
  Pem pem;
  for (auto [path, flag, out] :
       {std::tuple{&cert, "--tls_cert", &pem.cert}, std::tuple{&key, "--tls_key", &pem.key},
        std::tuple{&client_ca, "--tls_client_ca", &pem.client_ca}}) {
    if (path->empty()) continue;
    absl::StatusOr<std::string> text = ReadPem(*path, flag);
    if (!text.ok()) return text.status();
    *out = *std::move(text);
  }
  return pem;
}

}  // namespace skimap::server::auth
