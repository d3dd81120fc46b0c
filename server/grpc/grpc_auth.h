// The gRPC side of authentication: the caller's grant from the call's `authorization`
// metadata ("Bearer <token>"), asked of the one Authorizer (server/core/auth/authorizer.h), and the
// reactors that refuse a call before it starts.
//
//   ServerUnaryReactor* GrpcMapService::GetMap(ctx, request, response) {
//     if (absl::Status s = CheckMapCall(auth, ctx, auth::MethodRole("MapService/GetMap"),
//                                       request->name()).status();
//         !s.ok()) return Refuse(ctx, s);
//     ...
//
// A null authorizer (no --auth_tokens_file) grants everything. The health and reflection
// services are not checked (they hold no map data).
//
// Thread safety: pure functions of their arguments.
#ifndef SERVER_GRPC_GRPC_AUTH_H_
#define SERVER_GRPC_GRPC_AUTH_H_

#include <grpcpp/grpcpp.h>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "server/core/auth/authorizer.h"
#include "server/grpc/grpc_status.h"

namespace skimap::server {

// Authorizer::Authorize on the call's `authorization` metadata; Grant::Everything() when
// `auth` is null.
absl::StatusOr<auth::Grant> CheckCall(const auth::Authorizer* auth,
                                      const grpc::CallbackServerContext* ctx, auth::Role needed);
// The same for a call about the map `resource` names (Authorizer::AuthorizeMap).
absl::StatusOr<auth::Grant> CheckMapCall(const auth::Authorizer* auth,
                                         const grpc::CallbackServerContext* ctx, auth::Role needed,
                                         absl::string_view resource);

// Finishes a unary call with `status` (an error).
inline grpc::ServerUnaryReactor* Refuse(grpc::CallbackServerContext* ctx,
                                        const absl::Status& status) {
  grpc::ServerUnaryReactor* reactor = ctx->DefaultReactor();
  reactor->Finish(ToGrpcStatus(status));
  return reactor;
}

// A streaming call refused before it starts (Base: ServerReadReactor<T>, ServerWriteReactor<T>
// or ServerBidiReactor<R, W>): finishes at once with the status; deletes itself when done.
template <class Base>
class RefusedCall final : public Base {
 public:
  explicit RefusedCall(const absl::Status& status) { this->Finish(ToGrpcStatus(status)); }
  void OnDone() override { delete this; }
};

}  // namespace skimap::server

#endif  // SERVER_GRPC_GRPC_AUTH_H_
