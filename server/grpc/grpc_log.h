// gRPC's own log messages through skimapd's log (server/core/logging/log.h), so that with
// --log_format=json every stderr line is one JSON object ("msg": "grpc: ...").
//
//   SetLogFormat(LogFormat::kJson);
//   RouteGrpcLogToLog();
//
// Thread safety: call once at start, before gRPC logs anything.
#ifndef SERVER_GRPC_GRPC_LOG_H_
#define SERVER_GRPC_GRPC_LOG_H_

namespace skimap::server {

void RouteGrpcLogToLog();

}  // namespace skimap::server

#endif  // SERVER_GRPC_GRPC_LOG_H_
