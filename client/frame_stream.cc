#include "client/frame_stream.h"

#include "client/map_client.h"

namespace skimap::client {

FrameStream::FrameStream(v1::MapService::Stub* stub, const Options& options)
    : options_(options), call_(stub->StreamFrames(&context_)) {
  reader_ = std::thread([this] { ReadLoop(); });
}

FrameStream::~FrameStream() {
  if (!finished_) {
    context_.TryCancel();
    (void)Finish();
  }
}

void FrameStream::ReadLoop() {
  v1::FrameAck ack;
  while (call_->Read(&ack)) {
    if (options_.on_ack) options_.on_ack(ack);
    {
      std::lock_guard<std::mutex> lock(mu_);
      --unacked_;
      acks_.push_back(ack);
    }
    cv_.notify_all();
  }
  {
    std::lock_guard<std::mutex> lock(mu_);
    reader_done_ = true;
  }
  cv_.notify_all();
}

absl::Status FrameStream::Send(const v1::Frame& frame) {
  const int window = options_.window < 1 ? 1 : options_.window;
  {
    std::unique_lock<std::mutex> lock(mu_);
    cv_.wait(lock, [this, window] { return reader_done_ || unacked_ < window; });
    if (reader_done_) return absl::UnavailableError("frame stream closed by the server");
    ++unacked_;
  }
  if (!call_->Write(frame)) return absl::UnavailableError("frame stream broken");
  return absl::OkStatus();
}

absl::StatusOr<std::vector<v1::FrameAck>> FrameStream::Finish() {
  finished_ = true;
  call_->WritesDone();
  reader_.join();
  const grpc::Status status = call_->Finish();
  if (!status.ok()) return FromGrpcStatus(status);
  std::lock_guard<std::mutex> lock(mu_);
  return std::move(acks_);
}

}  // namespace skimap::client
