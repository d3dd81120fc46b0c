// CallObserver: a gRPC server interceptor on every call of skimapd's gRPC server. It gives
// the call its request id (the client's `x-request-id` metadata when sane, else a new
// one: logging/request_context.h), makes it the current request of the threads that run
// the handler, echoes it in the trailing metadata (`x-request-id`), and when the status is
// sent records the call's latency by method and code (metrics/metrics.h) and writes its
// access line (logging/log.h: method, map, code, latency_ms). Metadata values other than
// `x-request-id` are never read, so credentials never reach a log line.
//
//   builder.experimental().SetInterceptorCreators(MakeCallObservers(metrics));
//
// Thread safety: one interceptor per call; gRPC runs its hooks one batch at a time.
#ifndef SERVER_GRPC_CALL_OBSERVER_H_
#define SERVER_GRPC_CALL_OBSERVER_H_

#include <grpcpp/support/server_interceptor.h>

#include <memory>
#include <vector>

#include "server/core/metrics/metrics.h"

namespace skimap::server {

// The interceptor factories to register; `metrics` (may be null: no metrics) must outlive
// the gRPC server.
std::vector<std::unique_ptr<grpc::experimental::ServerInterceptorFactoryInterface>>
MakeCallObservers(Metrics* metrics);

}  // namespace skimap::server

#endif  // SERVER_GRPC_CALL_OBSERVER_H_
