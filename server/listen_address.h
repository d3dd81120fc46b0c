// Whether a gRPC listen address stays on this machine.
//
//   IsLoopbackAddress("127.0.0.1:50051")  // true; also localhost:P, [::1]:P, unix:PATH
//   IsLoopbackAddress("0.0.0.0:50051")    // false: every interface
//
// skimapd listens on loopback unless told otherwise: binding any other address needs
// GrpcServer::Options::insecure (skimapd --insecure) until authentication exists.
//
// Thread safety: pure function.
#ifndef SERVER_LISTEN_ADDRESS_H_
#define SERVER_LISTEN_ADDRESS_H_

#include <string>

namespace skimap::server {

bool IsLoopbackAddress(const std::string& address);

}  // namespace skimap::server

#endif  // SERVER_LISTEN_ADDRESS_H_
