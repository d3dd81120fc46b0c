// HttpCall: what HttpServer does around every request it dispatches: the request id (the
// `X-Request-Id` header when sane, else a new one; logging/request_context.h), current on
// the handler's thread and echoed in the `X-Request-Id` response header; and, when the
// request is answered, its latency by route and status (metrics/metrics.h) and its access
// line (logging/log.h: route, map, code, latency_ms). No other header is read, so
// credentials (Authorization) never reach a log line.
//
//   void HttpServer::Dispatch(const httplib::Request& request, httplib::Response& response) {
//     HttpCall call(request, response, options_.metrics);
//     call.SetRoute("GET /v1/maps/{map}", "maps/kitchen");
//     ...
//   }   // recorded here, with response.status
//
// Thread safety: one per request, on the request's thread.
#ifndef SERVER_HTTP_HTTP_CALL_H_
#define SERVER_HTTP_HTTP_CALL_H_

#include <optional>
#include <string>

#include "absl/time/time.h"
#include "server/core/logging/request_context.h"
#include "server/core/metrics/metrics.h"

namespace httplib {
struct Request;
struct Response;
}  // namespace httplib

namespace skimap::server {

class HttpCall {
 public:
  // `metrics` may be null (no metrics). REQUIRES: request and response outlive this.
  HttpCall(const httplib::Request& request, httplib::Response& response, Metrics* metrics);
  ~HttpCall();  // records the call with response.status
  HttpCall(const HttpCall&) = delete;
  HttpCall& operator=(const HttpCall&) = delete;

  // The route that answers ("GET /v1/maps/{map}"; "static" for the viewer's files) and the
  // map it names ("maps/kitchen", may be empty). Until set: "none".
  void SetRoute(std::string route, std::string map);

 private:
  const httplib::Response& response_;
  Metrics* const metrics_;
  const absl::Time start_;
  std::string route_ = "none";
  std::string map_;
  std::shared_ptr<const RequestContext> context_;
  std::optional<ScopedRequest> scope_;
};

}  // namespace skimap::server

#endif  // SERVER_HTTP_HTTP_CALL_H_
