// RestRoute: one entry of the REST route table (rest_routes.h), as HttpServer dispatches it
// and as the OpenAPI document (openapi.json) describes it.
//
//   RestRoute{"GET", "/v1/maps/{map}", [](const RestCall& call) -> absl::StatusOr<RestReply> {
//     ... call.path.at("map") ...
//   }}
//
// Path templates follow OpenAPI: literal segments and `{name}` parameters; a parameter
// matches one non-empty segment without '/' or ':' (so `/v1/maps/{map}:radiusSearch` and
// `/v1/maps/{map}` never match the same path).
//
// Thread safety: a route is immutable once the server started; handlers run concurrently
// on the HTTP threads and must be thread safe.
#ifndef SERVER_HTTP_REST_ROUTE_H_
#define SERVER_HTTP_REST_ROUTE_H_

#include <functional>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "server/core/auth/grant.h"

namespace skimap::server {

// What a handler sees of a request (valid during the call): the values of the path
// template's parameters by name ("map" -> "kitchen"), the query parameters (decoded, in
// order), the body and the Accept header, and the caller's grant (auth/grant.h: already
// checked for the route's role and its {map}; a route that names a map elsewhere, or
// lists maps, checks it against the scope).
struct RestCall {
  std::map<std::string, std::string> path;
  const std::multimap<std::string, std::string>& query;
  const std::string& body;
  std::string accept;
  const auth::Grant* grant = nullptr;  // null: no authorization (a test calling directly)
};

// A successful answer (status 200). Errors are absl::Status values, turned into a
// RestError body by HttpServer (http_status.h).
struct RestReply {
  std::string content_type = "application/json";
  std::string body;
  // Extra response headers (X-Skimap-Resolution, ...).
  std::vector<std::pair<std::string, std::string>> headers;
  // A streamed body instead of `body` (server-sent events, event_streams.h): runs on the
  // HTTP thread after the headers went out and writes pieces with `write`, which answers
  // false once the client is gone; the response ends when it returns.
  std::function<void(const std::function<bool(std::string_view)>& write)> stream;
};

using RestHandler = std::function<absl::StatusOr<RestReply>(const RestCall&)>;

struct RestRoute {
  std::string method;  // "GET", "POST" or "DELETE"
  std::string path;    // OpenAPI path template, e.g. "/v1/maps/{map}/occupancyGrid"
  RestHandler handler;
};

}  // namespace skimap::server

#endif  // SERVER_HTTP_REST_ROUTE_H_
