#include "server/core/auth/access.h"

namespace skimap::server::auth {
namespace {

constexpr std::optional<Role> kPublic = std::nullopt;

const MethodAccess kMethods[] = {
    {"MapService/CreateMap", Role::kWrite},
    {"MapService/GetMap", Role::kRead},
    {"MapService/ListMaps", Role::kRead},
    {"MapService/DeleteMap", Role::kAdmin},
    {"MapService/StreamFrames", Role::kWrite},
    {"MapService/IntegrateFrame", Role::kWrite},
    {"MapService/UpdatePoses", Role::kWrite},
    {"MapService/GetOccupancyGrid", Role::kRead},
    {"MapService/GetHeightMap", Role::kRead},
    {"MapService/GetVoxels", Role::kRead},
    {"MapService/StreamVoxels", Role::kRead},
    {"MapService/RadiusSearch", Role::kRead},
    {"MapService/ExportMap", Role::kAdmin},
    {"MapService/ImportMap", Role::kWrite},
    {"MapService/ListInstances", Role::kRead},
    {"MapService/GetInstance", Role::kRead},
    {"MapService/WatchInstances", Role::kRead},
    {"MapService/GetLabelVoxels", Role::kRead},
    {"ObjectService/TrainObject", Role::kAdmin},
    {"ObjectService/TrainObjectFromDataset", Role::kAdmin},
    {"ObjectService/AddObjectModel", Role::kAdmin},
    {"ObjectService/ListObjects", Role::kRead},
    {"ObjectService/GetObject", Role::kRead},
    {"ObjectService/DeleteObject", Role::kAdmin},
    {"ObjectService/BuildClassifier", Role::kAdmin},
    {"ObjectService/GetClassifier", Role::kRead},
    {"ObjectService/ClassifyImage", Role::kRead},
    {"ObjectService/GetOperation", Role::kRead},
    {"ObjectService/WaitOperation", Role::kRead},
    {"FleetService/ListNodes", Role::kRead},
};

const RouteAccess kRoutes[] = {
    {"GET", "/healthz", "", kPublic},
    {"GET", "/v1/openapi.json", "", kPublic},
    {"GET", "/v1/maps", "MapService/ListMaps", {}},
    {"POST", "/v1/maps", "MapService/CreateMap", {}},
    {"GET", "/v1/maps/{map}", "MapService/GetMap", {}},
    {"DELETE", "/v1/maps/{map}", "MapService/DeleteMap", {}},
    {"GET", "/v1/maps/{map}/occupancyGrid", "MapService/GetOccupancyGrid", {}},
    {"GET", "/v1/maps/{map}/heightMap", "MapService/GetHeightMap", {}},
    {"GET", "/v1/maps/{map}/voxels", "MapService/GetVoxels", {}},
    // The trajectory and the event stream are views of the map for the viewer.
    {"GET", "/v1/maps/{map}/trajectory", "", Role::kRead},
    {"GET", "/v1/maps/{map}/events", "", Role::kRead},
    {"POST", "/v1/maps/{map}:radiusSearch", "MapService/RadiusSearch", {}},
    {"POST", "/v1/maps/{map}/frames", "MapService/IntegrateFrame", {}},
    {"POST", "/v1/maps/{map}:updatePoses", "MapService/UpdatePoses", {}},
    {"GET", "/v1/maps/{map}/labels", "MapService/GetLabelVoxels", {}},
    {"GET", "/v1/maps/{map}/instances", "MapService/ListInstances", {}},
    {"GET", "/v1/maps/{map}/instances/{id}", "MapService/GetInstance", {}},
    {"GET", "/v1/objects", "ObjectService/ListObjects", {}},
    {"GET", "/v1/objects/{object}", "ObjectService/GetObject", {}},
    {"GET", "/metrics", "", Role::kRead},  // public with metrics_public
};

const RouteAccess* FindRoute(absl::string_view http_method, absl::string_view path) {
  for (const RouteAccess& route : kRoutes) {
    if (route.http_method == http_method && route.path == path) return &route;
  }
  return nullptr;
}

}  // namespace

absl::Span<const MethodAccess> MethodTable() { return kMethods; }
absl::Span<const RouteAccess> RouteTable() { return kRoutes; }

Role MethodRole(absl::string_view method) {
  for (const MethodAccess& entry : kMethods) {
    if (entry.method == method) return entry.role;
  }
  return Role::kAdmin;
}

std::optional<Role> RouteRole(absl::string_view http_method, absl::string_view path,
                              bool metrics_public) {
  if (path == "/metrics" && metrics_public) return kPublic;
  const RouteAccess* route = FindRoute(http_method, path);
  if (route == nullptr) return Role::kAdmin;
  if (!route->serves.empty()) return MethodRole(route->serves);
  return route->role;
}

bool RouteListed(absl::string_view http_method, absl::string_view path) {
  return FindRoute(http_method, path) != nullptr;
}

}  // namespace skimap::server::auth
