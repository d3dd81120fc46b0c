// FrameStream: the client side of one StreamFrames call, with a send window.
//
// Send() writes a frame and blocks while `window` frames are unacknowledged; a reader
// thread collects acks as they arrive. Finish() half-closes, waits for the remaining acks
// and returns all of them (in arrival order) or the call's error.
//
// Thread safety: Send and Finish from one thread; Cancel from any; the ack callback runs on
// the reader thread.
#ifndef CLIENT_FRAME_STREAM_H_
#define CLIENT_FRAME_STREAM_H_

#include <grpcpp/grpcpp.h>

#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "absl/status/statusor.h"
#include "skimap/v1/map_service.grpc.pb.h"

namespace skimap::client {

class FrameStream {
 public:
  struct Options {
    int window = 8;  // unacknowledged frames before Send blocks, >= 1
    std::function<void(const v1::FrameAck&)> on_ack;  // optional, on the reader thread
  };
  // Starts the call on `stub` (not owned; must outlive the stream).
  FrameStream(v1::MapService::Stub* stub, const Options& options);
  ~FrameStream();  // cancels the call if Finish was not called

  // Sends one frame. Unavailable/Cancelled... if the call has failed (see Finish).
  absl::Status Send(const v1::Frame& frame);
  // Ends the stream; returns every ack, or the call's status if it failed.
  absl::StatusOr<std::vector<v1::FrameAck>> Finish();
  // Cancels the call from any thread: a blocked Send returns an error, Finish returns
  // CANCELLED (a server that stopped answering cannot hold its caller forever).
  void Cancel() { context_.TryCancel(); }

 private:
  void ReadLoop();

  const Options options_;
  grpc::ClientContext context_;
  std::unique_ptr<grpc::ClientReaderWriter<v1::Frame, v1::FrameAck>> call_;
  std::mutex mu_;  // std::mutex so that TSan sees it (Debian's Abseil is uninstrumented)
  std::condition_variable cv_;
  int unacked_ = 0;                 // guarded by mu_
  bool reader_done_ = false;        // guarded by mu_
  std::vector<v1::FrameAck> acks_;  // guarded by mu_
  bool finished_ = false;
  std::thread reader_;
};

}  // namespace skimap::client

#endif  // CLIENT_FRAME_STREAM_H_
