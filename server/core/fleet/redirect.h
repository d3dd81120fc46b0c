// Redirects: the error a fleet node answers for a map that another live node owns, as an
// absl::Status (code Unavailable, a message naming the owner, and a skimap.v1.MapRedirect
// payload), and its two wire forms: the status details of a gRPC call
// (skimap.v1.StatusDetails, wire-compatible with google.rpc.Status) and FrameAck.redirect.
//
//   return RedirectError("kitchen", "node-3f2a", "10.0.0.7:50051");
//   if (std::optional<v1::MapRedirect> r = RedirectOf(status)) ack.mutable_redirect()->...;
//
// Thread safety: pure functions.
#ifndef SERVER_CORE_FLEET_REDIRECT_H_
#define SERVER_CORE_FLEET_REDIRECT_H_

#include <optional>
#include <string>

#include "absl/status/status.h"
#include "skimap/v1/fleet.pb.h"

namespace skimap::server {

// Unavailable: map `id` is served by `node` at `address`.
absl::Status RedirectError(const std::string& id, const std::string& node,
                           const std::string& address);
// The redirect a status carries, if any.
std::optional<v1::MapRedirect> RedirectOf(const absl::Status& status);
// The serialized skimap.v1.StatusDetails of `status` (its code, message and redirect), or
// "" when it carries no redirect (plain code and message say everything).
std::string StatusDetailsOf(const absl::Status& status, const std::string& message);

}  // namespace skimap::server

#endif  // SERVER_CORE_FLEET_REDIRECT_H_
