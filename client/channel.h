// How a client reaches skimapd: plain text or TLS (the CA that signed the server's
// certificate, and a client certificate for mTLS), and the bearer token sent on every call.
//
//   absl::StatusOr<Connection> c = Connection::FromFiles({.token_file = "robot.token",
//                                                         .tls_ca = "ca.pem"});
//   auto client = MapClient::Connect("maps.example:50051", {.connection = *c});
//
// The token travels as the metadata `authorization: Bearer <token>` (a client interceptor
// adds it to every call of the channel, streams included). Without a token file the
// environment variable SKIMAP_TOKEN is used, if set.
//
// Thread safety: values and pure functions; channels are thread safe.
#ifndef CLIENT_CHANNEL_H_
#define CLIENT_CHANNEL_H_

#include <grpcpp/grpcpp.h>

#include <memory>
#include <string>

#include "absl/status/statusor.h"

namespace skimap::client {

struct Connection {
  std::string token;  // bearer token; "" = none
  bool tls = false;   // TLS with the fields below (an empty CA: the system's roots)
  std::string tls_ca_pem;
  std::string tls_cert_pem;  // client certificate chain (mTLS), with tls_key_pem
  std::string tls_key_pem;

  // File names as the CLI takes them (each "" = not given).
  struct Files {
    std::string token_file;  // the token on its first line (surrounding whitespace dropped)
    std::string tls_ca, tls_cert, tls_key;
  };
  // Reads the files; TLS when any of tls_ca / tls_cert / tls_key is given; the token from
  // token_file, else from $SKIMAP_TOKEN. NotFound naming the flag and path of a file that
  // cannot be read; InvalidArgument for tls_cert without tls_key or the reverse, or an
  // empty token file. Messages never hold the token.
  static absl::StatusOr<Connection> FromFiles(const Files& files);
};

// A channel to `target` with `connection`'s credentials and token, and the given message
// size limits.
std::shared_ptr<grpc::Channel> MakeChannel(const std::string& target, int max_message_bytes,
                                           const Connection& connection = {});

}  // namespace skimap::client

#endif  // CLIENT_CHANNEL_H_
