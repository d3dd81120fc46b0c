#include "server/grpc/grpc_auth.h"

namespace skimap::server {
namespace {

absl::string_view AuthorizationOf(const grpc::CallbackServerContext* ctx) {
  const auto& metadata = ctx->client_metadata();
  auto it = metadata.find("authorization");
  if (it == metadata.end()) return {};
  return absl::string_view(it->second.data(), it->second.size());
}

}  // namespace

absl::StatusOr<auth::Grant> CheckCall(const auth::Authorizer* auth,
                                      const grpc::CallbackServerContext* ctx, auth::Role needed) {
  if (auth == nullptr) return auth::Grant::Everything();
  return auth->Authorize(AuthorizationOf(ctx), needed);
}

absl::StatusOr<auth::Grant> CheckMapCall(const auth::Authorizer* auth,
                                         const grpc::CallbackServerContext* ctx, auth::Role needed,
                                         absl::string_view resource) {
  if (auth == nullptr) return auth::Grant::Everything();
  return auth->AuthorizeMap(AuthorizationOf(ctx), needed, resource);
}

}  // namespace skimap::server
