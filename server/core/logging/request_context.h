// RequestContext: the call a piece of work belongs to: its request id (`x-request-id`, the
// client's when it is sane, else one made here) and its gRPC method or REST route. The
// adapters set it for the thread that runs a call (ScopedRequest); WorkQueue hands it on
// to the tasks that thread submits (a frame's integration on the map's worker), and every
// log line (log.h) written meanwhile carries the id.
//
//   ScopedRequest scope(std::make_shared<RequestContext>(
//       RequestContext{.id = RequestIdFrom(header), .method = "GET /v1/maps"}));
//   ...  // LogInfo(...) here and in the tasks queued from here carry the id
//
// Thread safety: CurrentRequest and ScopedRequest act on the calling thread only; a
// RequestContext is immutable once shared.
#ifndef SERVER_CORE_LOGGING_REQUEST_CONTEXT_H_
#define SERVER_CORE_LOGGING_REQUEST_CONTEXT_H_

#include <memory>
#include <string>
#include <string_view>

namespace skimap::server {

struct RequestContext {
  std::string id;      // 1..128 characters of [A-Za-z0-9._:-]
  std::string method;  // "skimap.v1.MapService/GetMap" or "GET /v1/maps/{map}"
};

// The calling thread's current call, or null outside any.
const std::shared_ptr<const RequestContext>& CurrentRequest();

// Makes `context` the calling thread's current call until destroyed, then restores the
// previous one (scopes nest). Must be destroyed on the thread that made it.
class ScopedRequest {
 public:
  explicit ScopedRequest(std::shared_ptr<const RequestContext> context);
  ~ScopedRequest();
  ScopedRequest(const ScopedRequest&) = delete;
  ScopedRequest& operator=(const ScopedRequest&) = delete;

 private:
  std::shared_ptr<const RequestContext> previous_;
};

// The request id of a call whose client sent `given` (empty if none): `given` itself if it
// is 1..128 characters of [A-Za-z0-9._:-] (nothing else can reach a log line), else a new
// random id of 16 hex digits.
std::string RequestIdFrom(std::string_view given);

}  // namespace skimap::server

#endif  // SERVER_CORE_LOGGING_REQUEST_CONTEXT_H_
