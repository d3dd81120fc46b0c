#include "client/cli/dataset_frame_source.h"

#include <algorithm>
#include <utility>

#include "client/cli/dataset_frames.h"

namespace skimap::client {

absl::StatusOr<std::unique_ptr<FrameSource>> DatasetFrameSource::Open(
    const std::string& path, const FrameSourceOptions& options) {
  absl::StatusOr<std::vector<dataset::Frame>> frames = LoadDatasetFrames(path);
  if (!frames.ok()) return frames.status();
  Options source_options;
  source_options.depth_encoding = options.depth_encoding;
  return std::make_unique<DatasetFrameSource>(
      KeepEvery(*std::move(frames), options.every, options.max_frames), source_options);
}

DatasetFrameSource::DatasetFrameSource(std::vector<dataset::Frame> frames, const Options& options)
    : frames_(std::move(frames)),
      depth_encoding_(options.depth_encoding),
      read_ahead_(static_cast<size_t>(std::max({1, options.threads, options.read_ahead}))) {
  const size_t threads = std::min(static_cast<size_t>(std::max(1, options.threads)),
                                  std::max<size_t>(1, frames_.size()));
  for (size_t i = 0; i < threads; ++i) workers_.emplace_back([this] { WorkerLoop(); });
}

DatasetFrameSource::~DatasetFrameSource() {
  {
    MutexLock lock(&mu_);
    stop_ = true;
  }
  work_cv_.SignalAll();
  for (std::thread& worker : workers_) worker.join();
}

void DatasetFrameSource::WorkerLoop() {
  MutexLock lock(&mu_);
  while (true) {
    while (!stop_ && next_claim_ < frames_.size() && next_claim_ - next_yield_ >= read_ahead_) {
      work_cv_.Wait(&mu_);
    }
    if (stop_ || next_claim_ >= frames_.size()) return;
    const size_t index = next_claim_++;
    ahead_.emplace_back();
    lock.Unlock();
    // Map and sequence are the stream's to set.
    FrameOrError frame =
        ToApiFrame(frames_[index], /*map_name=*/"", /*sequence=*/0, depth_encoding_);
    lock.Lock();
    // next_yield_ <= index: Next() does not pass a frame still in preparation.
    ahead_[index - next_yield_] = std::move(frame);
    ready_cv_.SignalAll();
  }
}

absl::StatusOr<std::optional<FrameOrError>> DatasetFrameSource::Next() {
  MutexLock lock(&mu_);
  if (next_yield_ >= frames_.size()) return std::optional<FrameOrError>();
  while (ahead_.empty() || !ahead_.front().has_value()) ready_cv_.Wait(&mu_);
  std::optional<FrameOrError> frame = std::move(ahead_.front());
  ahead_.pop_front();
  ++next_yield_;
  work_cv_.Signal();
  return frame;
}

}  // namespace skimap::client
