// Fleet: what a skimapd node of a fleet adds to a single server, built from its flags: the
// shared PostgreSQL store (opened with a fresh node id) and the FleetNode (leases,
// membership, redirects). Server (server/app/server.h) opens it from Options::fleet and wires
// it in (the map store, the map service's ownership hook, and the gRPC adapter of the
// FleetService over node(): server/grpc/fleet_grpc_service.h).
//
//   absl::StatusOr<std::unique_ptr<Fleet>> fleet =
//       Fleet::Open("postgresql://skimap@db/skimap", {.address = "10.0.0.7:50051"});
//   ... the map service on (*fleet)->store() and node(), GrpcFleetService on node() ...
//   (*fleet)->node().Leave();   // after the server (and its last snapshots) is gone
//
// Thread safety: the members are thread safe.
#ifndef SERVER_CORE_FLEET_FLEET_H_
#define SERVER_CORE_FLEET_FLEET_H_

#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "server/core/fleet/fleet_node.h"
#include "storage/postgres_map_store.h"

namespace skimap::server {

class Fleet {
 public:
  // Connects to `store_url` as a new node (id: host name + random suffix; the store opened
  // with `store` and options.lease_ttl), registers it with `options.address` and starts
  // heartbeating. InvalidArgument for an address that other nodes cannot reach (0.0.0.0,
  // [::], empty); the store's error otherwise.
  static absl::StatusOr<std::unique_ptr<Fleet>> Open(const std::string& store_url,
                                                     const FleetNode::Options& options,
                                                     storage::PostgresMapStore::Options store = {});

  storage::PostgresMapStore& store() { return *store_; }
  FleetNode& node() { return *node_; }

 private:
  Fleet() = default;
  std::unique_ptr<storage::PostgresMapStore> store_;  // first: outlives the node
  std::unique_ptr<FleetNode> node_;
};

}  // namespace skimap::server

#endif  // SERVER_CORE_FLEET_FLEET_H_
