// The access table: the role each call of the API needs, declared once and read by both
// adapters (docs/operations.md, "Authentication").
//
//   MethodRole("MapService/CreateMap")             // Role::kWrite (the gRPC adapter)
//   RouteRole("POST", "/v1/maps")                   // Role::kWrite: it serves CreateMap
//   RouteRole("GET", "/healthz")                    // nullopt: public
//
// Every gRPC method of skimap.v1 has one entry ("Service/Method"), naming its role. Every
// REST route has one entry too: the gRPC method it serves (its role is that method's), or,
// for a route with no gRPC twin (health, the OpenAPI document, the viewer's trajectory and
// event stream, metrics), a role of its own. A method or route the table does not list needs admin:
// a new call is closed until it is listed here (tests/server/auth/authorizer_test.cc checks that
// every method of the services and every served route has exactly one entry).
//
// Thread safety: pure functions over constant tables.
#ifndef SERVER_CORE_AUTH_ACCESS_H_
#define SERVER_CORE_AUTH_ACCESS_H_

#include <optional>

#include "absl/strings/string_view.h"
#include "absl/types/span.h"
#include "server/core/auth/grant.h"

namespace skimap::server::auth {

struct MethodAccess {
  absl::string_view method;  // "MapService/CreateMap": service and method of skimap.v1
  Role role;
};

struct RouteAccess {
  absl::string_view http_method;  // "GET", "POST", "DELETE"
  absl::string_view path;         // the route's template: "/v1/maps/{map}"
  absl::string_view serves;       // the gRPC method it serves (its role), or ""
  std::optional<Role> role;       // for a route that serves none: its role (nullopt: public)
};

absl::Span<const MethodAccess> MethodTable();
absl::Span<const RouteAccess> RouteTable();

// The role the gRPC method `method` ("Service/Method") needs; kAdmin for an unlisted one.
Role MethodRole(absl::string_view method);

// The role a REST route needs; nullopt for a public one. /metrics is public when
// `metrics_public` (skimapd --metrics_public), read otherwise; an unlisted route: kAdmin.
std::optional<Role> RouteRole(absl::string_view http_method, absl::string_view path,
                              bool metrics_public = true);
// True for the routes the table lists.
bool RouteListed(absl::string_view http_method, absl::string_view path);

}  // namespace skimap::server::auth

#endif  // SERVER_CORE_AUTH_ACCESS_H_
