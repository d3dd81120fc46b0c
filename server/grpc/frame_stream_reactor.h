// FrameStreamReactor: one StreamFrames call (gRPC callback API).
//
// Reads frames, hands each to MapService::IntegrateFrame and writes one FrameAck per frame
// in completion order. Backpressure: at most `max_in_flight` frames are read but not yet
// acknowledged; the next read starts only when an ack has been written, so a fast client
// is held back by HTTP/2 flow control instead of growing a server queue. A bad frame gets
// its error code and message in its ack and the stream goes on. When the client half-closes,
// the call finishes OK after the last ack; a cancelled call drops the pending acks.
//
// Thread safety: gRPC and map workers call in concurrently; state is under mu_, and the
// reactor operations (StartRead/StartWrite/Finish) are issued after releasing it.
#ifndef SERVER_GRPC_FRAME_STREAM_REACTOR_H_
#define SERVER_GRPC_FRAME_STREAM_REACTOR_H_

#include <grpcpp/grpcpp.h>

#include <deque>
#include <memory>

#include "absl/base/thread_annotations.h"
#include "base/rw_lock.h"
#include "server/core/auth/grant.h"
#include "server/core/logging/request_context.h"
#include "server/core/maps/map_service.h"
#include "server/grpc/stream_limiter.h"
#include "skimap/v1/frames.pb.h"

namespace skimap::server {

class FrameStreamReactor final : public grpc::ServerBidiReactor<v1::Frame, v1::FrameAck> {
 public:
  // REQUIRES: core outlives the call; max_in_flight >= 1. Deletes itself in OnDone,
  // releasing `slot` (the client's stream count) with it. A frame for a map outside
  // `grant`'s scope is not integrated: its ack carries PERMISSION_DENIED.
  FrameStreamReactor(MapService* core, int max_in_flight, StreamLimiter::Slot slot = {},
                     auth::Grant grant = auth::Grant::Everything());

  void OnReadDone(bool ok) override;
  void OnWriteDone(bool ok) override;
  void OnDone() override { delete this; }

 private:
  void OnFrameDone(uint64_t sequence, absl::StatusOr<v1::FrameAck> result);
  // Decides, under mu_, which of read / write / finish to start; starts them unlocked.
  void Step();

  MapService* const core_;
  // The call's request (call_observer.h), current while a frame is handed to the core.
  const std::shared_ptr<const RequestContext> request_ = CurrentRequest();
  const int max_in_flight_;
  StreamLimiter::Slot slot_;
  const auth::Grant grant_;
  RwLock mu_;
  std::shared_ptr<v1::Frame> reading_ ABSL_GUARDED_BY(mu_);
  v1::FrameAck writing_ ABSL_GUARDED_BY(mu_);
  std::deque<v1::FrameAck> acks_ ABSL_GUARDED_BY(mu_);  // done, not yet written
  int in_flight_ ABSL_GUARDED_BY(mu_) = 0;              // read, ack not yet written
  bool read_pending_ ABSL_GUARDED_BY(mu_) = false;
  bool reads_done_ ABSL_GUARDED_BY(mu_) = false;
  bool write_pending_ ABSL_GUARDED_BY(mu_) = false;
  bool broken_ ABSL_GUARDED_BY(mu_) = false;  // a write failed: the client is gone
  bool finished_ ABSL_GUARDED_BY(mu_) = false;
};

}  // namespace skimap::server

#endif  // SERVER_GRPC_FRAME_STREAM_REACTOR_H_
