#include "server/core/auth/tls_files.h"

#include <openssl/bio.h>
#include <openssl/pem.h>
#include <openssl/x509.h>

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

// OK when `key_pem` is the private key of the first certificate of `cert_pem`.
absl::Status CheckKeyMatches(const TlsFiles& files, const TlsFiles::Pem& pem) {
  BIO* cert_bio = BIO_new_mem_buf(pem.cert.data(), static_cast<int>(pem.cert.size()));
  X509* cert = PEM_read_bio_X509(cert_bio, nullptr, nullptr, nullptr);
  BIO_free(cert_bio);
  BIO* key_bio = BIO_new_mem_buf(pem.key.data(), static_cast<int>(pem.key.size()));
  EVP_PKEY* key = PEM_read_bio_PrivateKey(key_bio, nullptr, nullptr, nullptr);
  BIO_free(key_bio);
  absl::Status status;
  if (cert == nullptr) {
    status = absl::InvalidArgumentError(
        absl::StrCat("--tls_cert ", files.cert, ": holds no PEM certificate"));
  } else if (key == nullptr) {
    status = absl::InvalidArgumentError(
        absl::StrCat("--tls_key ", files.key, ": holds no PEM private key (or an encrypted one)"));
  } else if (X509_check_private_key(cert, key) != 1) {
    status = absl::InvalidArgumentError(
        absl::StrCat("--tls_key ", files.key, " is not the key of --tls_cert ", files.cert));
  }
  X509_free(cert);
  EVP_PKEY_free(key);
  return status;
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
  if (absl::Status s = CheckKeyMatches(*this, pem); !s.ok()) return s;
  return pem;
}

}  // namespace skimap::server::auth
