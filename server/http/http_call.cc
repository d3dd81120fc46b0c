#include "server/http/http_call.h"

#include <httplib.h>

#include <utility>

#include "absl/time/clock.h"
#include "server/core/logging/log.h"

namespace skimap::server {

HttpCall::HttpCall(const httplib::Request& request, httplib::Response& response, Metrics* metrics)
    : response_(response), metrics_(metrics), start_(absl::Now()) {
  const std::string id = RequestIdFrom(request.get_header_value("X-Request-Id"));
  response.set_header("X-Request-Id", id);
  context_ = std::make_shared<RequestContext>(
      RequestContext{.id = id, .method = request.method + " (no route)"});
  scope_.emplace(context_);
}

void HttpCall::SetRoute(std::string route, std::string map) {
  route_ = std::move(route);
  map_ = std::move(map);
  context_ = std::make_shared<RequestContext>(RequestContext{.id = context_->id, .method = route_});
  scope_.reset();
  scope_.emplace(context_);
}

HttpCall::~HttpCall() {
  const absl::Duration latency = absl::Now() - start_;
  if (metrics_ != nullptr) metrics_->HttpCallDone(route_, response_.status, latency);
  Log({.level = LogLevel::kInfo,
       .msg = "call",
       .map = map_,
       .code = response_.status,
       .latency = latency,
       .access = true});
}

}  // namespace skimap::server
