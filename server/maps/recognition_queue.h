// RecognitionQueue: the thread that runs a map's recognition stage behind its mapping
// (docs/recognition.md, "Scheduling"). Jobs are frames that were integrated and
// journaled; the queue takes them by the map's policy:
//   - newest: one pending job at most; a new frame replaces a pending one, which is
//     skipped (counted). Mapping and its acks never wait.
//   - every frame: every job, in order; each job's `done` (the frame's ack) runs after
//     the job, so a client is held to the recognition rate by its own in-flight window.
// Revotes (after UpdatePoses) are not used: see LiveMap. A job whose map goes away before
// it runs still gets its `done` call (with what was recognised so far).
//
//   RecognitionQueue q({.every_frame = false}, [&](RecognitionJob& job) { Recognize(job); });
//   q.Offer(std::move(job));
//
// Thread safety: Offer may be called from any thread; the run function runs on the queue's
// own thread, one job at a time.
#ifndef SERVER_MAPS_RECOGNITION_QUEUE_H_
#define SERVER_MAPS_RECOGNITION_QUEUE_H_

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <thread>

#include "perception/rgbd_frame.h"

namespace skimap::server {

struct RecognitionJob {
  uint64_t sequence = 0;
  int64_t time_us = 0;  // the frame's timestamp (unix µs), 0 if it had none
  std::shared_ptr<const perception::RgbdFrame> frame;
  std::function<void()> done;  // every-frame policy: the frame's ack; may be null
};

class RecognitionQueue {
 public:
  struct Options {
    bool every_frame = false;
  };
  // Starts the thread. `run` is called with each job taken (then the job's done).
  RecognitionQueue(const Options& options, std::function<void(RecognitionJob&)> run);
  // Stops taking jobs, waits for the running one, calls `done` of the pending ones.
  ~RecognitionQueue();
  RecognitionQueue(const RecognitionQueue&) = delete;
  RecognitionQueue& operator=(const RecognitionQueue&) = delete;

  void Offer(RecognitionJob job);
  // Jobs replaced before they ran (policy newest).
  uint64_t skipped() const { return skipped_.load(std::memory_order_relaxed); }
  // Returns once every job offered before the call has run (tests, clean stops).
  void Flush();

 private:
  void Loop();

  const Options options_;
  const std::function<void(RecognitionJob&)> run_;
  std::atomic<uint64_t> skipped_{0};
  std::mutex mu_;
  std::condition_variable cv_;
  std::deque<RecognitionJob> jobs_;  // guarded by mu_
  bool running_ = false;             // guarded by mu_: a job is being run
  bool stopping_ = false;            // guarded by mu_
  std::thread thread_;
};

}  // namespace skimap::server

#endif  // SERVER_MAPS_RECOGNITION_QUEUE_H_
