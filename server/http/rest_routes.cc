#include "server/http/rest_routes.h"

#include <functional>
#include <future>
#include <memory>
#include <set>
#include <string>
#include <utility>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "base/echo.h"
#include "server/core/auth/access.h"
#include "server/core/recognition/instance_queries.h"
#include "server/http/openapi_json.h"  // generated from openapi.json (CMakeLists.txt)
#include "server/http/raster_images.h"
#include "server/http/rest_messages.h"
#include "server/http/rest_request.h"
#include "skimap/v1/rest.pb.h"

namespace skimap::server {
namespace {

RestReply JsonReply(const google::protobuf::Message& message) {
  return RestReply{.content_type = "application/json", .body = ToJson(message)};
}

// The media type of the protobuf binary encoding.
constexpr char kProtobuf[] = "application/x-protobuf";

// The reply message as JSON, or in the protobuf binary encoding (the gRPC answer's bytes)
// when the Accept header names application/x-protobuf: the viewer reads voxel pages so,
// since printing JSON costs the server 15-60x what the page itself does
// (docs/benchmarks.md, "REST vs gRPC").
RestReply MessageReply(const RestCall& call, const google::protobuf::Message& message) {
  if (absl::StrContains(call.accept, kProtobuf)) {
    return RestReply{.content_type = kProtobuf, .body = message.SerializeAsString()};
  }
  return JsonReply(message);
}

// A route whose reply is the core method's reply message, as JSON or protobuf (MessageReply).
template <class Request, class Reply>
RestHandler Unary(Body body, std::vector<Binding> bindings,
                  std::function<absl::StatusOr<Reply>(const Request&)> method) {
  return [body, bindings = std::move(bindings),
          method = std::move(method)](const RestCall& call) -> absl::StatusOr<RestReply> {
    absl::StatusOr<Request> request = ParseRequest<Request>(call, body, bindings);
    if (!request.ok()) return request.status();
    absl::StatusOr<Reply> reply = method(*request);
    if (!reply.ok()) return reply.status();
    return MessageReply(call, *reply);
  };
}

// Waits for a core method that answers through a callback (run exactly once, on any thread).
template <class T>
absl::StatusOr<T> Await(const std::function<void(std::function<void(absl::StatusOr<T>)>)>& start) {
  auto promise = std::make_shared<std::promise<absl::StatusOr<T>>>();
  std::future<absl::StatusOr<T>> future = promise->get_future();
  start([promise](absl::StatusOr<T> result) { promise->set_value(std::move(result)); });
  return future.get();
}

// The picture format a raster route answers: ?format= first, then the Accept header;
// JSON by default.
absl::StatusOr<RasterFormat> FormatOf(const RestCall& call, bool pgm) {
  if (auto it = call.query.find("format"); it != call.query.end()) {
    const std::string& format = it->second;
    if (format == "json") return RasterFormat::kJson;
    if (format == "png") return RasterFormat::kPng;
    if (format == "pgm" && pgm) return RasterFormat::kPgm;
    return absl::InvalidArgumentError(absl::StrCat("query parameter format: ", Echo(format),
                                                   " is not one of json, png", pgm ? ", pgm" : ""));
  }
  const std::string& accept = call.accept;
  if (pgm && absl::StrContains(accept, "image/x-portable-graymap")) return RasterFormat::kPgm;
  if (absl::StrContains(accept, "image/png")) return RasterFormat::kPng;
  return RasterFormat::kJson;
}

template <class Raster>
RestReply PictureReply(const Raster& raster, std::string bytes, RasterFormat format) {
  RestReply reply{
      .content_type = format == RasterFormat::kPgm ? "image/x-portable-graymap" : "image/png",
      .body = std::move(bytes)};
  reply.headers.emplace_back("X-Skimap-Resolution", absl::StrCat(raster.resolution()));
  reply.headers.emplace_back("X-Skimap-Origin",
                             absl::StrCat(raster.origin_x(), " ", raster.origin_y()));
  reply.headers.emplace_back("X-Skimap-Width", absl::StrCat(raster.width()));
  reply.headers.emplace_back("X-Skimap-Height", absl::StrCat(raster.height()));
  return reply;
}

const std::vector<Binding> kMap = {{"map", "maps/{map}"}};
const std::vector<Binding> kMapName = {{"name", "maps/{map}"}};

absl::StatusOr<RestReply> OccupancyGrid(const MapService& maps, const RestCall& call) {
  absl::StatusOr<RasterFormat> format = FormatOf(call, /*pgm=*/true);
  if (!format.ok()) return format.status();
  auto request = ParseRequest<v1::GetOccupancyGridRequest>(call, Body::kNone, kMap, {"format"});
  if (!request.ok()) return request.status();
  if (*format != RasterFormat::kJson && request->data_encoding() != v1::GRID_ENCODING_RAW) {
    return absl::InvalidArgumentError(
        "data_encoding: only with format=json (images are PNG or PGM)");
  }
  absl::StatusOr<v1::OccupancyGrid> grid = maps.GetOccupancyGrid(*request);
  if (!grid.ok()) return grid.status();
  if (*format == RasterFormat::kJson) return JsonReply(*grid);
  absl::StatusOr<std::string> image = EncodeOccupancyGrid(*grid, *format);
  if (!image.ok()) return image.status();
  return PictureReply(*grid, *std::move(image), *format);
}

absl::StatusOr<RestReply> HeightMap(const MapService& maps, const RestCall& call) {
  absl::StatusOr<RasterFormat> format = FormatOf(call, /*pgm=*/false);
  if (!format.ok()) return format.status();
  auto request = ParseRequest<v1::GetHeightMapRequest>(call, Body::kNone, kMap, {"format"});
  if (!request.ok()) return request.status();
  absl::StatusOr<v1::HeightMap> map = maps.GetHeightMap(*request);
  if (!map.ok()) return map.status();
  if (*format == RasterFormat::kJson) return JsonReply(*map);
  double z_offset = 0;
  absl::StatusOr<std::string> image = EncodeHeightMapPng(*map, &z_offset);
  if (!image.ok()) return image.status();
  RestReply reply = PictureReply(*map, *std::move(image), *format);
  reply.headers.emplace_back("X-Skimap-Z-Offset", absl::StrCat(z_offset));
  reply.headers.emplace_back("X-Skimap-Z-Scale", "0.001");
  return reply;
}

}  // namespace

const char* OpenApiJson() { return kOpenApiJson; }

RestRoute MetricsRoute(Metrics& metrics) {
  return {"GET", "/metrics", [&metrics](const RestCall&) -> absl::StatusOr<RestReply> {
            return RestReply{.content_type = "text/plain; version=0.0.4; charset=utf-8",
                             .body = metrics.Scrape()};
          }};
}

std::vector<RestRoute> MakeRestRoutes(MapService& maps, ObjectService& objects, MapEvents& events) {
  // The recognition routes' core, shared by their handlers (which the routes outlive).
  auto instances = std::make_shared<const InstanceQueries>(&maps);
  std::vector<RestRoute> routes;
  routes.push_back({"GET", "/healthz", [](const RestCall&) -> absl::StatusOr<RestReply> {
                      v1::HealthzResponse health;
                      health.set_status("SERVING");
                      return JsonReply(health);
                    }});
  routes.push_back({"GET", "/v1/openapi.json", [](const RestCall&) -> absl::StatusOr<RestReply> {
                      return RestReply{.body = kOpenApiJson};
                    }});
  routes.push_back({"GET", "/v1/maps", [&maps](const RestCall& call) -> absl::StatusOr<RestReply> {
                      auto request = ParseRequest<v1::ListMapsRequest>(call, Body::kNone, {});
                      if (!request.ok()) return request.status();
                      absl::StatusOr<v1::ListMapsResponse> reply = maps.ListMaps(*request);
                      if (!reply.ok()) return reply.status();
                      if (call.grant != nullptr) auth::KeepMapsInScope(*call.grant, &*reply);
                      return JsonReply(*reply);
                    }});
  routes.push_back({"POST", "/v1/maps", [&maps](const RestCall& call) -> absl::StatusOr<RestReply> {
                      auto request = ParseRequest<v1::CreateMapRequest>(call, Body::kJson, {});
                      if (!request.ok()) return request.status();
                      if (call.grant != nullptr) {  // the map is named in the body
                        if (absl::Status s =
                                call.grant->CheckMap(auth::MethodRole("MapService/CreateMap"),
                                                     "maps/" + request->map_id());
                            !s.ok()) {
                          return s;
                        }
                      }
                      absl::StatusOr<v1::Map> map = maps.CreateMap(*request);
                      if (!map.ok()) return map.status();
                      return JsonReply(*map);
                    }});
  routes.push_back({"GET", "/v1/maps/{map}",
                    Unary<v1::GetMapRequest, v1::Map>(
                        Body::kNone, kMapName, [&maps](const auto& r) { return maps.GetMap(r); })});
  routes.push_back(
      {"DELETE", "/v1/maps/{map}",
       Unary<v1::DeleteMapRequest, v1::DeleteMapResponse>(
           Body::kNone, kMapName, [&maps](const auto& r) -> absl::StatusOr<v1::DeleteMapResponse> {
             if (absl::Status s = maps.DeleteMap(r); !s.ok()) return s;
             return v1::DeleteMapResponse();
           })});
  routes.push_back({"GET", "/v1/maps/{map}/occupancyGrid",
                    [&maps](const RestCall& call) { return OccupancyGrid(maps, call); }});
  routes.push_back({"GET", "/v1/maps/{map}/heightMap",
                    [&maps](const RestCall& call) { return HeightMap(maps, call); }});
  routes.push_back({"GET", "/v1/maps/{map}/voxels",
                    Unary<v1::GetVoxelsRequest, v1::GetVoxelsResponse>(
                        Body::kNone, kMap, [&maps](const auto& r) { return maps.GetVoxels(r); })});
  routes.push_back(
      {"GET", "/v1/maps/{map}/trajectory",
       Unary<v1::GetTrajectoryRequest, v1::Trajectory>(
           Body::kNone, kMap, [&maps](const auto& r) { return maps.GetTrajectory(r); })});
  routes.push_back({"GET", "/v1/maps/{map}/events",
                    [&events](const RestCall& call) { return events.Open(call); }});
  routes.push_back(
      {"POST", "/v1/maps/{map}:radiusSearch",
       Unary<v1::RadiusSearchRequest, v1::RadiusSearchResponse>(
           Body::kJson, kMap, [&maps](const auto& r) { return maps.RadiusSearch(r); })});
  routes.push_back(
      {"POST", "/v1/maps/{map}/frames",
       Unary<v1::Frame, v1::FrameAck>(Body::kJson, kMap, [&maps](const v1::Frame& frame) {
         return Await<v1::FrameAck>([&](LiveMap::FrameDone done) {
           maps.IntegrateFrame(std::make_shared<v1::Frame>(frame), std::move(done));
         });
       })});
  routes.push_back({"POST", "/v1/maps/{map}:updatePoses",
                    Unary<v1::UpdatePosesRequest, v1::UpdatePosesResponse>(
                        Body::kJson, kMap, [&maps](const v1::UpdatePosesRequest& r) {
                          return Await<v1::UpdatePosesResponse>([&](LiveMap::PosesDone done) {
                            maps.UpdatePoses(std::make_shared<v1::UpdatePosesRequest>(r),
                                             std::move(done));
                          });
                        })});
  routes.push_back(
      {"GET", "/v1/maps/{map}/instances",
       Unary<v1::ListInstancesRequest, v1::ListInstancesResponse>(
           Body::kNone, kMap, [instances](const auto& r) { return instances->ListInstances(r); })});
  routes.push_back({"GET", "/v1/maps/{map}/instances/{id}",
                    Unary<v1::GetInstanceRequest, v1::Instance>(
                        Body::kNone, {{"name", "maps/{map}/instances/{id}"}},
                        [instances](const auto& r) { return instances->GetInstance(r); })});
  routes.push_back({"GET", "/v1/maps/{map}/labels",
                    Unary<v1::GetLabelVoxelsRequest, v1::GetLabelVoxelsResponse>(
                        Body::kNone, kMap,
                        [instances](const auto& r) { return instances->GetLabelVoxels(r); })});
  routes.push_back(
      {"GET", "/v1/objects",
       Unary<v1::ListObjectsRequest, v1::ListObjectsResponse>(
           Body::kNone, {}, [&objects](const auto& r) { return objects.ListObjects(r); })});
  routes.push_back({"GET", "/v1/objects/{object}",
                    Unary<v1::GetObjectRequest, v1::Object>(
                        Body::kNone, {{"name", "objects/{object}"}},
                        [&objects](const auto& r) { return objects.GetObject(r); })});
  return routes;
}

}  // namespace skimap::server
