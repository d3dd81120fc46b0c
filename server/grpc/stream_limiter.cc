#include "server/grpc/stream_limiter.h"

#include <utility>

#include "absl/strings/str_cat.h"
#include "base/echo.h"

namespace skimap::server {

StreamLimiter::Slot& StreamLimiter::Slot::operator=(Slot&& o) noexcept {
  if (this != &o) {
    if (limiter_ != nullptr) limiter_->Release(client_);
    limiter_ = std::exchange(o.limiter_, nullptr);
    client_ = std::move(o.client_);
  }
  return *this;
}

StreamLimiter::Slot::~Slot() {
  if (limiter_ != nullptr) limiter_->Release(client_);
}

std::string StreamLimiter::ClientOf(const std::string& peer) {
  const size_t colon = peer.rfind(':');
  const size_t scheme = peer.find(':');
  // "ipv4:host:port" / "ipv6:[addr]:port": drop the port; anything else is its own client.
  if (colon == std::string::npos || colon == scheme) return peer;
  return peer.substr(0, colon);
}

absl::StatusOr<StreamLimiter::Slot> StreamLimiter::Acquire(const std::string& peer) {
  std::string client = ClientOf(peer);
  if (max_per_client_ <= 0) return Slot();
  MutexLock lock(&mu_);
  int& open = open_[client];
  if (open >= max_per_client_) {
    return absl::ResourceExhaustedError(absl::StrCat(
        "client ", Echo(client), " has ", open, " StreamFrames calls open, the limit is ",
        max_per_client_, " per client (skimapd --max_streams_per_client)"));
  }
  ++open;
  return Slot(this, std::move(client));
}

int StreamLimiter::Open(const std::string& peer) {
  MutexLock lock(&mu_);
  auto it = open_.find(ClientOf(peer));
  return it == open_.end() ? 0 : it->second;
}

void StreamLimiter::Release(const std::string& client) {
  MutexLock lock(&mu_);
  auto it = open_.find(client);
  if (it != open_.end() && --it->second <= 0) open_.erase(it);
}

}  // namespace skimap::server
