// The REST API of skimapd: the route table, each route a few lines that turn the HTTP
// request into the gRPC API's request message (rest_messages.h), call the same core
// method the gRPC adapter calls, and answer its reply message as JSON (or a picture).
// Validation lives in the cores only: a REST client gets the gRPC client's messages.
//
//   GET    /healthz                          HealthzResponse
//   GET    /v1/openapi.json                  the OpenAPI 3 description (openapi.json)
//   GET    /v1/maps                          ListMaps          ?pageSize&pageToken
//   POST   /v1/maps                          CreateMap         body CreateMapRequest
//   GET    /v1/maps/{map}                    GetMap
//   DELETE /v1/maps/{map}                    DeleteMap
//   GET    /v1/maps/{map}/occupancyGrid      GetOccupancyGrid  ?region&bandMinZ&...&format
//   GET    /v1/maps/{map}/heightMap          GetHeightMap      ?region&minVoxelWeight&format
//   GET    /v1/maps/{map}/voxels             GetVoxels         ?box&pageSize&pageToken&level&...
//   GET    /v1/maps/{map}/trajectory         GetTrajectory     ?maxPoses
//   GET    /v1/maps/{map}/events             WatchMap          server-sent events (map_events.h)
//   POST   /v1/maps/{map}:radiusSearch       RadiusSearch      body RadiusSearchRequest
//   POST   /v1/maps/{map}/frames             IntegrateFrame    body Frame; reply FrameAck
//   POST   /v1/maps/{map}:updatePoses        UpdatePoses       body UpdatePosesRequest
//   GET    /v1/maps/{map}/instances          ListInstances     ?box|sphere&objIds&minScore&...
//   GET    /v1/maps/{map}/instances/{id}     GetInstance
//   GET    /v1/maps/{map}/labels             GetLabelVoxels    ?box&pageSize&pageToken&minCount
//   GET    /v1/objects                       ListObjects       ?pageSize&pageToken
//   GET    /v1/objects/{object}              GetObject         ?view
//   GET    /metrics                          Prometheus text exposition (MetricsRoute)
//
// The grid is JSON, a ROS map_server PGM (?format=pgm or Accept: image/x-portable-graymap)
// or a PNG (?format=png or Accept: image/png); the height map JSON or a 16-bit PNG.
// Picture replies carry the raster's geometry in headers: X-Skimap-Resolution (m),
// X-Skimap-Origin ("x y", m, the lower-left corner of cell (0, 0)), X-Skimap-Width /
// -Height (cells), and for the height map X-Skimap-Z-Offset / X-Skimap-Z-Scale (pixel
// value v means z = offset + v * scale; 0 unknown).
//
// Thread safety: the handlers hold references to the cores only; they are as thread safe
// as the cores (which are).
#ifndef SERVER_HTTP_REST_ROUTES_H_
#define SERVER_HTTP_REST_ROUTES_H_

#include <vector>

#include "server/core/maps/map_service.h"
#include "server/core/metrics/metrics.h"
#include "server/core/objects/object_service.h"
#include "server/http/map_events.h"
#include "server/http/rest_route.h"

namespace skimap::server {

// The route table over `maps`, `objects` and `events` (not owned; REQUIRES: all outlive
// every call of the routes' handlers).
std::vector<RestRoute> MakeRestRoutes(MapService& maps, ObjectService& objects, MapEvents& events);

// GET /metrics: `metrics`' text exposition (not owned; REQUIRES: outlives every call).
RestRoute MetricsRoute(Metrics& metrics);

// The OpenAPI 3 document served at /v1/openapi.json (server/http/openapi.json, compiled in).
const char* OpenApiJson();

}  // namespace skimap::server

#endif  // SERVER_HTTP_REST_ROUTES_H_
