// DatasetFrameSource: the frames of a dataset folder (client/cli/dataset_frames.h: BOP
// scene, TUM sequence, BOP root) as a FrameSource, prepared ahead on worker threads.
//
// Reading a frame's files and re-encoding its depth (16-bit PNG decoded, zstd or RVL
// encoded: ToApiFrame) takes the client more CPU than sending it. `threads` workers
// prepare the next frames concurrently while the caller sends earlier ones; at most
// `read_ahead` prepared or in-preparation frames are held (bounded memory: about 1 MB
// each at 640x480). Next() yields them in the dataset's order, a frame that could not be
// prepared (a missing file) as its own error, after which the source goes on.
//
//   absl::StatusOr<std::unique_ptr<FrameSource>> source = DatasetFrameSource::Open(dir, {});
//   while (true) {
//     absl::StatusOr<std::optional<FrameOrError>> next = (*source)->Next();
//     if (!next.ok() || !next->has_value()) break;  // a dataset source never fails here
//     ...
//   }
//
// Thread safety: total() and Next() from one thread at a time; the workers are internal
// and stop when the source is destroyed (frames not yet taken are dropped).
#ifndef CLIENT_CLI_DATASET_FRAME_SOURCE_H_
#define CLIENT_CLI_DATASET_FRAME_SOURCE_H_

#include <cstddef>
#include <deque>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "absl/status/statusor.h"
#include "base/mutex.h"
#include "client/cli/frame_source.h"
#include "dataset/types.h"

namespace skimap::client {

class DatasetFrameSource final : public FrameSource {
 public:
  struct Options {
    v1::DepthEncoding depth_encoding = kDepthAsStored;  // ToApiFrame's
    int threads = 2;                                    // workers preparing frames, >= 1
    int read_ahead = 8;  // frames prepared or in preparation at most, >= threads
  };

  // The frames of the dataset folder `path` (LoadDatasetFrames), every options.every-th,
  // at most options.max_frames (KeepEvery). NotFound / InvalidArgument from the reader.
  static absl::StatusOr<std::unique_ptr<FrameSource>> Open(const std::string& path,
                                                           const FrameSourceOptions& options);

  // Yields `frames` in order (their files are read only when prepared).
  DatasetFrameSource(std::vector<dataset::Frame> frames, const Options& options);
  ~DatasetFrameSource() override;
  DatasetFrameSource(const DatasetFrameSource&) = delete;
  DatasetFrameSource& operator=(const DatasetFrameSource&) = delete;

  size_t total() const override { return frames_.size(); }
  // Blocks until the next frame is prepared. Never an error status: a frame's error is
  // its FrameOrError.
  absl::StatusOr<std::optional<FrameOrError>> Next() override;

 private:
  void WorkerLoop();

  const std::vector<dataset::Frame> frames_;
  const v1::DepthEncoding depth_encoding_;
  const size_t read_ahead_;
  Mutex mu_;
  CondVar work_cv_;   // a slot freed, or stop_
  CondVar ready_cv_;  // a frame prepared
  // ahead_[k]: frame next_yield_ + k, nullopt while a worker prepares it; its size is
  // next_claim_ - next_yield_ <= read_ahead_.
  std::deque<std::optional<FrameOrError>> ahead_ ABSL_GUARDED_BY(mu_);
  size_t next_yield_ ABSL_GUARDED_BY(mu_) = 0;  // the frame Next() returns next
  size_t next_claim_ ABSL_GUARDED_BY(mu_) = 0;  // the frame a worker prepares next
  bool stop_ ABSL_GUARDED_BY(mu_) = false;
  std::vector<std::thread> workers_;
};

}  // namespace skimap::client

#endif  // CLIENT_CLI_DATASET_FRAME_SOURCE_H_
