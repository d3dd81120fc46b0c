// skimapd's log: one line per event on stderr, as text ("skimapd: <msg>", the default) or,
// with --log_format=json, as one JSON object per line:
//
//   {"time":"2026-11-26T01:02:03.456Z","level":"info","msg":"map maps/kitchen created",
//    "request_id":"3f9a0c1d2e4b5a69","method":"skimap.v1.MapService/CreateMap",
//    "map":"maps/kitchen","code":0,"latency_ms":1.25}
//
// `request_id` (and `method` / `route`) come from the calling thread's RequestContext
// (request_context.h), so the core's lines of a call carry the id of its access line.
// Access lines (one per finished call: method or route, map, code, latency_ms) are written
// in the JSON format only; the text format keeps the messages only. gRPC's own messages go
// through the same writer (server/grpc/grpc_log.h, which skimapd installs with the JSON
// format), so every stderr line is one JSON object.
// Nothing here reads request headers or metadata: credentials never reach a log line.
//
// Thread safety: Log* may be called from any thread (whole lines, never interleaved);
// SetLogFormat once at start, before other threads log.
#ifndef SERVER_CORE_LOGGING_LOG_H_
#define SERVER_CORE_LOGGING_LOG_H_

#include <optional>
#include <string_view>

#include "absl/time/time.h"

namespace skimap::server {

enum class LogFormat { kText, kJson };
enum class LogLevel { kInfo, kWarning, kError };

// The process's format (kText until set).
void SetLogFormat(LogFormat format);
LogFormat GetLogFormat();

struct LogEntry {
  LogLevel level = LogLevel::kInfo;
  std::string_view msg;
  std::string_view map;     // "maps/kitchen", empty if none
  std::optional<int> code;  // gRPC code or HTTP status of a finished call
  std::optional<absl::Duration> latency;
  bool access = false;  // an access line (JSON format only)
};
void Log(const LogEntry& entry);

inline void LogInfo(std::string_view msg) { Log({.level = LogLevel::kInfo, .msg = msg}); }
inline void LogWarning(std::string_view msg) { Log({.level = LogLevel::kWarning, .msg = msg}); }
inline void LogError(std::string_view msg) { Log({.level = LogLevel::kError, .msg = msg}); }

}  // namespace skimap::server

#endif  // SERVER_CORE_LOGGING_LOG_H_
