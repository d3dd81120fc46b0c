#include "server/grpc/fleet_grpc_service.h"

#include "server/core/auth/access.h"
#include "server/grpc/grpc_auth.h"
#include "server/grpc/grpc_status.h"

namespace skimap::server {

grpc::ServerUnaryReactor* GrpcFleetService::ListNodes(grpc::CallbackServerContext* ctx,
                                                      const v1::ListNodesRequest* request,
                                                      v1::ListNodesResponse* response) {
  // The nodes' addresses and the maps each serves: the read role.
  if (absl::Status s = CheckCall(auth_, ctx, auth::MethodRole("FleetService/ListNodes")).status();
      !s.ok()) {
    return Refuse(ctx, s);
  }
  return Reply(ctx, node_->ListNodes(), response);
}

}  // namespace skimap::server
