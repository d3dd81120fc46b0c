// StreamLimiter: caps the open StreamFrames calls per client, a client being its peer
// address without the port (every connection from one host counts together).
//
//   StreamLimiter limiter(16);
//   absl::StatusOr<StreamLimiter::Slot> slot = limiter.Acquire(ctx->peer());
//   if (!slot.ok()) ...;   // ResourceExhausted naming the limit and the flag
//   // the slot frees itself when destroyed (with the call's reactor)
//
// Thread safety: thread safe. A Slot must not outlive its limiter.
#ifndef SERVER_GRPC_STREAM_LIMITER_H_
#define SERVER_GRPC_STREAM_LIMITER_H_

#include <string>

#include "absl/base/thread_annotations.h"
#include "absl/container/flat_hash_map.h"
#include "absl/status/statusor.h"
#include "base/mutex.h"

namespace skimap::server {

class StreamLimiter {
 public:
  // One open stream of one client; releases it when destroyed. Move-only.
  class Slot {
   public:
    Slot() = default;
    Slot(Slot&& o) noexcept : limiter_(o.limiter_), client_(std::move(o.client_)) {
      o.limiter_ = nullptr;
    }
    Slot& operator=(Slot&& o) noexcept;
    ~Slot();

   private:
    friend class StreamLimiter;
    Slot(StreamLimiter* limiter, std::string client)
        : limiter_(limiter), client_(std::move(client)) {}
    StreamLimiter* limiter_ = nullptr;
    std::string client_;
  };

  // At most `max_per_client` open streams per client; 0 = no limit.
  explicit StreamLimiter(int max_per_client) : max_per_client_(max_per_client) {}

  // A slot for a stream from `peer` (gRPC's "ipv4:127.0.0.1:5555" / "ipv6:[::1]:5555"), or
  // ResourceExhausted when the client already has max_per_client streams open.
  absl::StatusOr<Slot> Acquire(const std::string& peer);
  // Open streams of the client of `peer`.
  int Open(const std::string& peer);

  // The client of a peer: its address without the port.
  static std::string ClientOf(const std::string& peer);

 private:
  void Release(const std::string& client);

  const int max_per_client_;
  Mutex mu_;
  absl::flat_hash_map<std::string, int> open_ ABSL_GUARDED_BY(mu_);
};

}  // namespace skimap::server

#endif  // SERVER_GRPC_STREAM_LIMITER_H_
