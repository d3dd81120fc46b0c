#include "server/core/logging/log.h"

#include <atomic>
#include <cstdio>
#include <mutex>
#include <nlohmann/json.hpp>
#include <string>

#include "absl/time/clock.h"
#include "server/core/logging/request_context.h"

namespace skimap::server {
namespace {

std::atomic<LogFormat> format{LogFormat::kText};
std::mutex write_mu;  // whole lines

const char* LevelName(LogLevel level) {
  switch (level) {
    case LogLevel::kInfo:
      return "info";
    case LogLevel::kWarning:
      return "warning";
    case LogLevel::kError:
      return "error";
  }
  return "info";
}

void WriteLine(const std::string& line) {
  std::lock_guard<std::mutex> lock(write_mu);
  std::fwrite(line.data(), 1, line.size(), stderr);
  std::fflush(stderr);
}

}  // namespace

void SetLogFormat(LogFormat f) { format.store(f, std::memory_order_release); }

LogFormat GetLogFormat() { return format.load(std::memory_order_acquire); }

void Log(const LogEntry& entry) {
  if (GetLogFormat() == LogFormat::kText) {
    if (!entry.access) WriteLine("skimapd: " + std::string(entry.msg) + "\n");
    return;
  }
  nlohmann::ordered_json line;
  line["time"] = absl::FormatTime("%Y-%m-%dT%H:%M:%E3SZ", absl::Now(), absl::UTCTimeZone());
  line["level"] = LevelName(entry.level);
  line["msg"] = entry.msg;
  if (const std::shared_ptr<const RequestContext>& call = CurrentRequest(); call != nullptr) {
    line["request_id"] = call->id;
    // REST routes start with their HTTP method ("GET /v1/maps"); gRPC methods do not.
    const bool rest = call->method.find(' ') != std::string::npos;
    line[rest ? "route" : "method"] = call->method;
  }
  if (!entry.map.empty()) line["map"] = entry.map;
  if (entry.code) line["code"] = *entry.code;
  if (entry.latency) line["latency_ms"] = absl::ToDoubleMilliseconds(*entry.latency);
  // Invalid UTF-8 (a client's bytes in a message) is replaced, never thrown.
  WriteLine(line.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n");
}

}  // namespace skimap::server
