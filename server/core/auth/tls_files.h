// TlsFiles: the certificate files of skimapd's TLS (--tls_cert, --tls_key, --tls_client_ca),
// for the gRPC port (grpc::SslServerCredentials) and the REST port (HTTPS) alike.
//
//   TlsFiles tls{.cert = "server.pem", .key = "server.key", .client_ca = "ca.pem"};
//   absl::StatusOr<TlsFiles::Pem> pem = tls.Read();   // the PEM text of each file
//
// Without `cert` and `key` the port speaks plain text. With `client_ca` every client must
// present a certificate signed by that CA (mTLS); others fail the TLS handshake.
//
// Thread safety: a value; Read is a pure function of the files.
#ifndef SERVER_CORE_AUTH_TLS_FILES_H_
#define SERVER_CORE_AUTH_TLS_FILES_H_

#include <string>

#include "absl/status/statusor.h"

namespace skimap::server::auth {

struct TlsFiles {
  std::string cert;       // PEM certificate chain of the server; "" = plain text
  std::string key;        // PEM private key of `cert`
  std::string client_ca;  // PEM CA certificates that sign client certificates; "" = no mTLS

  bool enabled() const { return !cert.empty() || !key.empty(); }

  struct Pem {
    std::string cert, key, client_ca;
  };
  // Checks the combination (InvalidArgument: a key without a cert or the reverse, a client
  // CA without both), reads the files (NotFound naming the flag and the path; the contents
  // never appear in a message) and checks that the key is the certificate's
  // (InvalidArgument naming both flags).
  absl::StatusOr<Pem> Read() const;
};

}  // namespace skimap::server::auth

#endif  // SERVER_CORE_AUTH_TLS_FILES_H_
