#include "server/grpc/grpc_log.h"

#include <grpc/support/log.h>

#include <string>

#include "server/core/logging/log.h"

namespace skimap::server {
namespace {

void GrpcLog(gpr_log_func_args* args) {
  const LogLevel level = args->severity == GPR_LOG_SEVERITY_ERROR  ? LogLevel::kError
                         : args->severity == GPR_LOG_SEVERITY_INFO ? LogLevel::kInfo
                                                                   : LogLevel::kWarning;
  const std::string msg = std::string("grpc: ") + (args->message ? args->message : "");
  Log({.level = level, .msg = msg});
}

}  // namespace

void RouteGrpcLogToLog() { gpr_set_log_function(GrpcLog); }

}  // namespace skimap::server
