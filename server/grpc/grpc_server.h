// GrpcServer: the gRPC adapter of skimapd on one address: the MapService and
// ObjectService adapters over cores it does not own, the standard health service and
// server reflection (v1alpha in gRPC 1.51). Server (server/app/server.h) builds it.
//
//   absl::StatusOr<std::unique_ptr<GrpcServer>> grpc =
//       GrpcServer::Start({.address = "127.0.0.1:0"}, &maps, &objects);
//   int port = (*grpc)->port();   // the bound port ("...:0" picks a free one)
//   (*grpc)->Shutdown();          // stops accepting, cancels open calls after the grace
//
// Thread safety: Shutdown and Wait may be called from any thread; Shutdown is idempotent.
#ifndef SERVER_GRPC_GRPC_SERVER_H_
#define SERVER_GRPC_GRPC_SERVER_H_

#include <grpcpp/grpcpp.h>

#include <memory>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "server/core/auth/authorizer.h"
#include "server/core/auth/tls_files.h"
#include "server/core/maps/map_service.h"
#include "server/core/metrics/metrics.h"
#include "server/core/objects/object_service.h"
#include "server/grpc/grpc_service.h"
#include "server/grpc/object_grpc_service.h"

namespace skimap::server {

class GrpcServer {
 public:
  struct Options {
    // host:port; port 0 = any free port. Loopback unless `insecure` or `auth`
    // (listen_address.h).
    std::string address = "127.0.0.1:50051";
    // Allows an address beyond loopback without `auth`: anyone who can reach the port can
    // read and write every map.
    bool insecure = false;
    // Bearer-token authorization of every call but health and reflection (not owned;
    // outlives the server); null = none.
    const auth::Authorizer* auth = nullptr;
    // TLS (grpc::SslServerCredentials) with tls.cert and tls.key; client certificates
    // required and verified against tls.client_ca when given (mTLS). Plain text without.
    auth::TlsFiles tls;
    // The MapService adapter: in-flight frames per stream, streams per client, ...
    GrpcMapService::Options map_service;
    // Largest gRPC message accepted or sent. Frames with images above the map service's
    // max_frame_bytes get RESOURCE_EXHAUSTED in their ack; messages above this limit fail
    // the call with RESOURCE_EXHAUSTED.
    int max_message_bytes = 80 << 20;
    // Further gRPC services served on the same port (not owned; outlive the server), e.g.
    // a fleet node's FleetService.
    std::vector<grpc::Service*> more_services;
    // Request latency by method and code (not owned; outlives the server); null: none.
    // Request ids and access log lines (call_observer.h) are on either way.
    Metrics* metrics = nullptr;
  };

  // Binds and starts serving `maps` and `objects` (not owned; REQUIRES: both outlive the
  // server). FailedPrecondition for an address beyond loopback without `insecure` or
  // `auth`; the TLS files' errors (TlsFiles::Read); Unavailable if the address cannot be
  // bound.
  static absl::StatusOr<std::unique_ptr<GrpcServer>> Start(const Options& options, MapService* maps,
                                                           ObjectService* objects);
  ~GrpcServer();  // Shutdown()

  int port() const { return port_; }

  // Stops accepting calls, cancels open ones after `grace` and waits for them.
  void Shutdown(absl::Duration grace = absl::Seconds(2));
  // Blocks until Shutdown has completed (from another thread).
  void Wait() { server_->Wait(); }

 private:
  GrpcServer() = default;

  std::unique_ptr<GrpcObjectService> grpc_objects_;
  std::unique_ptr<GrpcMapService> grpc_maps_;
  std::unique_ptr<grpc::Server> server_;
  int port_ = 0;
};

}  // namespace skimap::server

#endif  // SERVER_GRPC_GRPC_SERVER_H_
