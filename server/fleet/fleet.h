// Fleet: what a skimapd node of a fleet adds to a single server, built from its flags: the
// shared PostgreSQL store (opened with a fresh node id), the FleetNode (leases, membership,
// redirects) and its FleetService adapter. Server (server/server.h) opens it from
// Options::fleet and wires it in (the map store, the map service's ownership hook, the
// FleetService on the gRPC port).
//
//   absl::StatusOr<std::unique_ptr<Fleet>> fleet =
//       Fleet::Open("postgresql://skimap@db/skimap", {.address = "10.0.0.7:50051"});
//   ... the map service and the gRPC adapter on (*fleet)->store(), node(), service() ...
//   (*fleet)->node().Leave();   // after the server (and its last snapshots) is gone
//
// Thread safety: the members are thread safe.
#ifndef SERVER_FLEET_FLEET_H_
#define SERVER_FLEET_FLEET_H_

#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "server/fleet/fleet_grpc_service.h"
#include "server/fleet/fleet_node.h"
#include "storage/postgres_map_store.h"

namespace skimap::server {

class Fleet {
 public:
  // Connects to `store_url` as a new node (id: host name + random suffix), registers it
  // with `options.address` and starts heartbeating. InvalidArgument for an address that
  // other nodes cannot reach (0.0.0.0, [::], empty); the store's error otherwise.
  static absl::StatusOr<std::unique_ptr<Fleet>> Open(const std::string& store_url,
                                                     const FleetNode::Options& options);

  storage::PostgresMapStore& store() { return *store_; }
  FleetNode& node() { return *node_; }
  GrpcFleetService& service() { return *service_; }

 private:
  Fleet() = default;
  std::unique_ptr<storage::PostgresMapStore> store_;  // first: outlives the node
  std::unique_ptr<FleetNode> node_;
  std::unique_ptr<GrpcFleetService> service_;
};

}  // namespace skimap::server

#endif  // SERVER_FLEET_FLEET_H_
