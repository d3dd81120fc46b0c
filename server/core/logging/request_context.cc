#include "server/core/logging/request_context.h"

#include <cstdio>
#include <random>
#include <utility>

#include "absl/strings/ascii.h"

namespace skimap::server {
namespace {

std::shared_ptr<const RequestContext>& Slot() {
  thread_local std::shared_ptr<const RequestContext> current;
  return current;
}

}  // namespace

const std::shared_ptr<const RequestContext>& CurrentRequest() { return Slot(); }

ScopedRequest::ScopedRequest(std::shared_ptr<const RequestContext> context)
    : previous_(std::exchange(Slot(), std::move(context))) {}

ScopedRequest::~ScopedRequest() { Slot() = std::move(previous_); }

std::string RequestIdFrom(std::string_view given) {
  bool sane = !given.empty() && given.size() <= 128;
  for (const char c : given) {
    sane = sane && (absl::ascii_isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' ||
                    c == ':' || c == '-');
  }
  if (sane) return std::string(given);
  thread_local std::mt19937_64 random{std::random_device{}()};
  char id[17];
  std::snprintf(id, sizeof id, "%016llx", static_cast<unsigned long long>(random()));
  return id;
}

}  // namespace skimap::server
