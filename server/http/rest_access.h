// Who may call which REST route: the role each (method, path template) of the route table
// needs, the REST half of the table in docs/operations.md ("Authentication"). The gRPC
// half lives in the handlers of grpc/ (each names its role), and both ask the same
// Authorizer (auth/authorizer.h).
//
//   RestRouteRole("GET", "/v1/maps/{map}")        // Role::kRead
//   RestRouteRole("DELETE", "/v1/maps/{map}")     // Role::kAdmin
//   RestRouteRole("GET", "/healthz")              // nullopt: public
//
// A route this table does not know needs admin (a new route is closed until it is listed
// here). Public: /healthz, /v1/openapi.json, the viewer's files (they hold no map data),
// and /metrics when `metrics_public`.
//
// Thread safety: pure function.
#ifndef SERVER_HTTP_REST_ACCESS_H_
#define SERVER_HTTP_REST_ACCESS_H_

#include <optional>

#include "absl/strings/string_view.h"
#include "server/auth/grant.h"

namespace skimap::server {

// The role the route needs; nullopt for a public route.
std::optional<auth::Role> RestRouteRole(absl::string_view method, absl::string_view path,
                                        bool metrics_public = true);

// True for the routes this table lists (a test checks that every served route is listed).
bool RestRouteListed(absl::string_view method, absl::string_view path);

}  // namespace skimap::server

#endif  // SERVER_HTTP_REST_ACCESS_H_
