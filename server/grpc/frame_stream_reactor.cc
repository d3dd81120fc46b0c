#include "server/grpc/frame_stream_reactor.h"

#include <utility>

#include "server/core/auth/access.h"
#include "server/core/fleet/redirect.h"

namespace skimap::server {

FrameStreamReactor::FrameStreamReactor(MapService* core, int max_in_flight,
                                       StreamLimiter::Slot slot, auth::Grant grant)
    : core_(core),
      max_in_flight_(max_in_flight < 1 ? 1 : max_in_flight),
      slot_(std::move(slot)),
      grant_(std::move(grant)) {
  Step();
}

void FrameStreamReactor::OnReadDone(bool ok) {
  std::shared_ptr<v1::Frame> frame;
  {
    WriterLock lock(&mu_);
    read_pending_ = false;
    if (!ok) {
      reads_done_ = true;
    } else {
      frame = std::move(reading_);
      ++in_flight_;
    }
  }
  if (frame) {
    ScopedRequest scope(request_);
    const uint64_t sequence = frame->sequence();
    if (!grant_.AllowsMap(frame->map())) {
      OnFrameDone(sequence,
                  grant_.CheckMap(auth::MethodRole("MapService/StreamFrames"), frame->map()));
      return;  // OnFrameDone stepped
    }
    core_->IntegrateFrame(std::move(frame), [this, sequence](absl::StatusOr<v1::FrameAck> r) {
      OnFrameDone(sequence, std::move(r));
    });
  }
  Step();
}

void FrameStreamReactor::OnFrameDone(uint64_t sequence, absl::StatusOr<v1::FrameAck> result) {
  v1::FrameAck ack;
  if (result.ok()) {
    ack = *std::move(result);
  } else {
    ack.set_sequence(sequence);
    ack.set_code(static_cast<int>(result.status().code()));
    ack.set_message(std::string(result.status().message()));
    if (std::optional<v1::MapRedirect> r = RedirectOf(result.status())) {
      *ack.mutable_redirect() = *std::move(r);
    }
  }
  {
    WriterLock lock(&mu_);
    acks_.push_back(std::move(ack));
  }
  Step();
}

void FrameStreamReactor::OnWriteDone(bool ok) {
  {
    WriterLock lock(&mu_);
    write_pending_ = false;
    --in_flight_;
    if (!ok) broken_ = true;
  }
  Step();
}

void FrameStreamReactor::Step() {
  v1::FrameAck* write = nullptr;
  v1::Frame* read = nullptr;
  bool finish = false;
  StreamLimiter::Slot ended;  // the client's stream slot, given back before Finish
  {
    WriterLock lock(&mu_);
    if (broken_) {
      in_flight_ -= static_cast<int>(acks_.size());
      acks_.clear();
    }
    if (!write_pending_ && !acks_.empty()) {
      writing_ = std::move(acks_.front());
      acks_.pop_front();
      write_pending_ = true;
      write = &writing_;
    }
    if (!read_pending_ && !reads_done_ && !broken_ && in_flight_ < max_in_flight_) {
      reading_ = std::make_shared<v1::Frame>();
      read_pending_ = true;
      read = reading_.get();
    }
    if ((reads_done_ || broken_) && !read_pending_ && in_flight_ == 0 && !write_pending_ &&
        !finished_) {
      finished_ = finish = true;
      ended = std::move(slot_);
    }
  }
  // The buffers stay untouched until the matching OnWriteDone / OnReadDone.
  if (write != nullptr) StartWrite(write);
  if (read != nullptr) StartRead(read);
  if (finish) {
    // Freed before the client sees the end: a stream it opens next counts without it.
    ended = StreamLimiter::Slot();
    Finish(grpc::Status::OK);
  }
}

}  // namespace skimap::server
