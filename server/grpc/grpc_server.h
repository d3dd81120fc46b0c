// GrpcServer: a running skimapd endpoint: the MapService core, its gRPC adapter, the
// ObjectService core and adapter, the standard health service and server reflection
// (v1alpha in gRPC 1.51), on one address.
//
//   absl::StatusOr<std::unique_ptr<GrpcServer>> server =
//       GrpcServer::Start({.address = "127.0.0.1:0"});
//   int port = (*server)->port();   // the bound port ("...:0" picks a free one)
//   (*server)->Shutdown();          // stops accepting, cancels calls, drains map workers
//
// Thread safety: Shutdown and Wait may be called from any thread; Shutdown is idempotent.
#ifndef SERVER_GRPC_GRPC_SERVER_H_
#define SERVER_GRPC_GRPC_SERVER_H_

#include <grpcpp/grpcpp.h>

#include <memory>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "server/grpc/grpc_service.h"
#include "server/grpc/object_grpc_service.h"
#include "server/maps/map_service.h"
#include "server/objects/object_service.h"
#include "storage/map_store.h"

namespace skimap::server {

class GrpcServer {
 public:
  struct Options {
    // host:port; port 0 = any free port. Loopback unless `insecure` (listen_address.h).
    std::string address = "127.0.0.1:50051";
    // Allows an address beyond loopback. There is no authentication yet: anyone who can
    // reach the port can read and write every map.
    bool insecure = false;
    MapService::Options service;
    // SQLite file where maps persist (skimapd: DATA_DIR/maps.sqlite): every frame and pose
    // update is journaled before its ack and the maps are reloaded at start. "" keeps maps
    // in memory only.
    std::string maps_db_path;
    // Or a store the caller owns (outlives the server), e.g. another backend or a test's
    // fault-injecting wrapper; takes precedence over maps_db_path.
    storage::MapStore* map_store = nullptr;
    GrpcMapService::Options grpc;
    // The object service; objects.db_path "" keeps its database in memory only.
    ObjectService::Options objects;
    // Largest gRPC message accepted or sent. Frames with images above
    // service.max_frame_bytes get RESOURCE_EXHAUSTED in their ack; messages above this
    // limit fail the call with RESOURCE_EXHAUSTED.
    int max_message_bytes = 80 << 20;
    // Further gRPC services served on the same port (not owned; outlive the server), e.g.
    // a fleet node's FleetService.
    std::vector<grpc::Service*> more_services;
  };

  // Binds and starts serving. FailedPrecondition for an address beyond loopback without
  // `insecure`; Unavailable if the address cannot be bound; the object database's load
  // error if it cannot be opened.
  static absl::StatusOr<std::unique_ptr<GrpcServer>> Start(const Options& options);
  ~GrpcServer();  // Shutdown()

  int port() const { return port_; }
  MapService& service() { return *core_; }
  ObjectService& object_service() { return *objects_; }

  // Stops accepting calls, cancels open ones after `grace` and waits for them.
  void Shutdown(absl::Duration grace = absl::Seconds(2));
  // Blocks until Shutdown has completed (from another thread).
  void Wait() { server_->Wait(); }

 private:
  GrpcServer() = default;

  std::unique_ptr<storage::MapStore> store_;  // before core_: outlives it
  std::unique_ptr<ObjectService> objects_;    // before core_: maps ask it for the classifier
  std::unique_ptr<GrpcObjectService> grpc_objects_;
  std::unique_ptr<MapService> core_;
  std::unique_ptr<GrpcMapService> grpc_service_;
  std::unique_ptr<grpc::Server> server_;
  int port_ = 0;
};

}  // namespace skimap::server

#endif  // SERVER_GRPC_GRPC_SERVER_H_
