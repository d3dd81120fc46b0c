#include "server/http/rest_access.h"

namespace skimap::server {
namespace {

using auth::Role;

struct RouteAccess {
  absl::string_view method;
  absl::string_view path;
  std::optional<Role> role;  // nullopt: public
};

constexpr std::optional<Role> kPublic = std::nullopt;

const RouteAccess kRoutes[] = {
    {"GET", "/healthz", kPublic},
    {"GET", "/v1/openapi.json", kPublic},
    {"GET", "/v1/maps", Role::kRead},
    {"POST", "/v1/maps", Role::kWrite},
    {"GET", "/v1/maps/{map}", Role::kRead},
    {"DELETE", "/v1/maps/{map}", Role::kAdmin},
    {"GET", "/v1/maps/{map}/occupancyGrid", Role::kRead},
    {"GET", "/v1/maps/{map}/heightMap", Role::kRead},
    {"GET", "/v1/maps/{map}/voxels", Role::kRead},
    {"GET", "/v1/maps/{map}/trajectory", Role::kRead},
    {"GET", "/v1/maps/{map}/events", Role::kRead},
    {"POST", "/v1/maps/{map}:radiusSearch", Role::kRead},
    {"POST", "/v1/maps/{map}/frames", Role::kWrite},
    {"POST", "/v1/maps/{map}:updatePoses", Role::kWrite},
    {"GET", "/v1/maps/{map}/labels", Role::kRead},
    {"GET", "/v1/maps/{map}/instances", Role::kRead},
    {"GET", "/v1/maps/{map}/instances/{id}", Role::kRead},
    {"GET", "/v1/objects", Role::kRead},
    {"GET", "/v1/objects/{object}", Role::kRead},
    {"GET", "/metrics", Role::kRead},  // public with metrics_public
};

const RouteAccess* Find(absl::string_view method, absl::string_view path) {
  for (const RouteAccess& route : kRoutes) {
    if (route.method == method && route.path == path) return &route;
  }
  return nullptr;
}

}  // namespace

std::optional<Role> RestRouteRole(absl::string_view method, absl::string_view path,
                                  bool metrics_public) {
  if (path == "/metrics" && metrics_public) return kPublic;
  const RouteAccess* route = Find(method, path);
  return route == nullptr ? Role::kAdmin : route->role;
}

bool RestRouteListed(absl::string_view method, absl::string_view path) {
  return Find(method, path) != nullptr;
}

}  // namespace skimap::server
