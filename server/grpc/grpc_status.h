// The one place where absl::Status becomes grpc::Status (codes are numerically equal), and
// the unary reply every callback handler ends with.
//
// Thread safety: pure functions.
#ifndef SERVER_GRPC_GRPC_STATUS_H_
#define SERVER_GRPC_GRPC_STATUS_H_

#include <grpcpp/grpcpp.h>
#include <grpcpp/support/status.h>

#include <string>
#include <utility>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "server/core/fleet/redirect.h"

namespace skimap::server {

// Status messages travel in response headers (grpc-message); longer ones are cut here so
// that no message can overflow them. Messages echo client text through Echo() anyway.
inline constexpr size_t kMaxStatusMessageBytes = 1024;

inline grpc::Status ToGrpcStatus(const absl::Status& s) {
  if (s.ok()) return grpc::Status::OK;
  std::string message(s.message().substr(0, kMaxStatusMessageBytes));
  if (s.message().size() > kMaxStatusMessageBytes) message += "...";
  // A fleet node's redirect travels in the status details (skimap.v1.StatusDetails).
  std::string details = StatusDetailsOf(s, message);
  return grpc::Status(static_cast<grpc::StatusCode>(s.code()), std::move(message),
                      std::move(details));
}

// Finishes a unary callback call with `result`: the value into *response, the status
// converted once.
template <class T>
grpc::ServerUnaryReactor* Reply(grpc::CallbackServerContext* ctx, absl::StatusOr<T> result,
                                T* response) {
  grpc::ServerUnaryReactor* reactor = ctx->DefaultReactor();
  if (result.ok()) *response = *std::move(result);
  reactor->Finish(ToGrpcStatus(result.status()));
  return reactor;
}

}  // namespace skimap::server

#endif  // SERVER_GRPC_GRPC_STATUS_H_
