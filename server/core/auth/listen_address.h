// Whether a listen address (gRPC or HTTP) stays on this machine.
//
//   IsLoopbackAddress("127.0.0.1:50051")  // true; also localhost:P, [::1]:P, unix:PATH
//   IsLoopbackAddress("0.0.0.0:50051")    // false: every interface
//
// skimapd listens on loopback unless told otherwise: binding any other address needs
// authentication (skimapd --auth_tokens_file) or `insecure` (skimapd --insecure, for the
// gRPC and the HTTP address alike).
//
// Thread safety: pure functions.
#ifndef SERVER_CORE_AUTH_LISTEN_ADDRESS_H_
#define SERVER_CORE_AUTH_LISTEN_ADDRESS_H_

#include <string>

#include "absl/status/status.h"

namespace skimap::server {

bool IsLoopbackAddress(const std::string& address);

// OK for a loopback address, or any address when `insecure` (true also when auth is
// configured); FailedPrecondition naming the address, its `flag` (e.g. "--http_address"),
// --auth_tokens_file and --insecure otherwise.
absl::Status CheckListenAddress(const std::string& address, bool insecure, const char* flag);

}  // namespace skimap::server

#endif  // SERVER_CORE_AUTH_LISTEN_ADDRESS_H_
