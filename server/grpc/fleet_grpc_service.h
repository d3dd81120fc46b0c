// GrpcFleetService: the gRPC adapter of skimap.v1.FleetService (fleet.proto) over a
// FleetNode. Route: ListNodes (unary).
//
// Thread safety: stateless apart from the node pointer; safe for concurrent calls.
#ifndef SERVER_GRPC_FLEET_GRPC_SERVICE_H_
#define SERVER_GRPC_FLEET_GRPC_SERVICE_H_

#include <grpcpp/grpcpp.h>

#include "server/core/auth/authorizer.h"
#include "server/core/fleet/fleet_node.h"
#include "skimap/v1/fleet.grpc.pb.h"

namespace skimap::server {

class GrpcFleetService final : public v1::FleetService::CallbackService {
 public:
  // REQUIRES: `node` outlives this service and its calls.
  explicit GrpcFleetService(FleetNode* node) : node_(node) {}
  // Calls need the read role of `auth` (not owned; outlives the service). REQUIRES: called
  // before the gRPC server that serves this service starts.
  void RequireAuth(const auth::Authorizer* auth) { auth_ = auth; }

  grpc::ServerUnaryReactor* ListNodes(grpc::CallbackServerContext* ctx,
                                      const v1::ListNodesRequest* request,
                                      v1::ListNodesResponse* response) override;

 private:
  FleetNode* const node_;
  const auth::Authorizer* auth_ = nullptr;
};

}  // namespace skimap::server

#endif  // SERVER_GRPC_FLEET_GRPC_SERVICE_H_
