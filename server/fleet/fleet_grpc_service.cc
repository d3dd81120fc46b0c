#include "server/fleet/fleet_grpc_service.h"

#include "server/grpc/grpc_status.h"

namespace skimap::server {

grpc::ServerUnaryReactor* GrpcFleetService::ListNodes(grpc::CallbackServerContext* ctx,
                                                      const v1::ListNodesRequest* request,
                                                      v1::ListNodesResponse* response) {
  return Reply(ctx, node_->ListNodes(), response);
}

}  // namespace skimap::server
