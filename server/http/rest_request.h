// How a REST route turns a request into its gRPC request message: the JSON body (protobuf
// JSON mapping, rest_messages.h), then the URL's query parameters, then the fields the path
// template binds ("maps/{map}" into `map`). The route table (rest_routes.cc) and the REST
// JSON fuzz target (tests/fuzz/rest_json_fuzz.cc) call the same ParseRequest.
//
//   absl::StatusOr<v1::RadiusSearchRequest> r = ParseRequest<v1::RadiusSearchRequest>(
//       call, Body::kJson, {{"map", "maps/{map}"}});
//
// Errors are InvalidArgument naming the input at fault ("body: ...", "query parameter
// pageSize: ...", "map: ...").
//
// Thread safety: pure functions of their arguments.
#ifndef SERVER_HTTP_REST_REQUEST_H_
#define SERVER_HTTP_REST_REQUEST_H_

#include <set>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "server/http/rest_messages.h"
#include "server/http/rest_route.h"

namespace skimap::server {

// A request field set from the path: `field` = `pattern` with {param}s replaced.
struct Binding {
  const char* field;    // "name"
  const char* pattern;  // "maps/{map}"
};

inline std::string Expand(const std::string& pattern, const RestCall& call) {
  std::string out = pattern;
  for (const auto& [param, value] : call.path) {
    const std::string key = absl::StrCat("{", param, "}");
    for (size_t at = out.find(key); at != std::string::npos; at = out.find(key, at)) {
      out.replace(at, key.size(), value);
      at += value.size();
    }
  }
  return out;
}

enum class Body { kNone, kJson };

// The route's request message: the JSON body (if the route takes one), then the query
// parameters (except `route_parameters`), then the path's bindings.
template <class Request>
absl::StatusOr<Request> ParseRequest(const RestCall& call, Body body,
                                     const std::vector<Binding>& bindings,
                                     const std::set<std::string>& route_parameters = {}) {
  Request request;
  if (body == Body::kJson) {
    if (absl::Status s = FromJsonBody(call.body, &request); !s.ok()) return s;
  }
  std::set<std::string> path_fields;
  for (const Binding& b : bindings) path_fields.insert(b.field);
  if (absl::Status s = FromQueryParameters(call.query, path_fields, route_parameters, &request);
      !s.ok()) {
    return s;
  }
  for (const Binding& b : bindings) {
    if (absl::Status s = BindPathField(b.field, Expand(b.pattern, call), &request); !s.ok()) {
      return s;
    }
  }
  return request;
}

}  // namespace skimap::server

#endif  // SERVER_HTTP_REST_REQUEST_H_
