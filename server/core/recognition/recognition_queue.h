// RecognitionQueue: the two threads that run a map's recognition stage behind its mapping
// (docs/recognition.md, "Scheduling"). Jobs are frames that were integrated and
// journaled. Each job goes through two steps in order: `prepare` (the frame's features and
// their classes: it reads the job's frame only) on the first thread, then `run` (labels
// fused, hypotheses voted, instances reconciled) on the second; so frame n+1 is prepared
// while frame n runs, and recognition uses two cores when mapping leaves them. The queue
// takes jobs by the map's policy:
//   - newest: one job at most waits before each step; a newer one replaces it, and the
//     replaced one is skipped (counted). A job is prepared only when no prepared job
//     waits (no work on frames that would be skipped). Mapping and its acks never wait.
//   - every frame: every job, in order; each job's `done` (the frame's ack) runs after
//     `run`, so a client is held to the recognition rate by its own in-flight window.
// Revotes (after UpdatePoses) are not used: see LiveMap. A job whose map goes away before
// it runs still gets its `done` call (with what was recognised so far).
//
//   RecognitionQueue q({.every_frame = false}, [&](RecognitionJob& job) { Observe(job); },
//                      [&](RecognitionJob& job) { Recognize(job); });
//   q.Offer(std::move(job));
//
// Thread safety: Offer may be called from any thread; `prepare` runs on the queue's first
// thread and `run` on its second, one job at a time each.
#ifndef SERVER_CORE_RECOGNITION_RECOGNITION_QUEUE_H_
#define SERVER_CORE_RECOGNITION_RECOGNITION_QUEUE_H_

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <thread>

#include "absl/status/statusor.h"
#include "perception/recognition/label_observer.h"
#include "perception/rgbd_frame.h"

namespace skimap::server {

struct RecognitionJob {
  uint64_t sequence = 0;
  int64_t time_us = 0;  // the frame's timestamp (unix µs), 0 if it had none
  std::shared_ptr<const perception::RgbdFrame> frame;
  std::function<void()> done;  // every-frame policy: the frame's ack; may be null
  // Set by `prepare` for `run`: the frame's label observations, or why there are none.
  absl::StatusOr<recognition::LabelObservations> observed = absl::UnknownError("not prepared");
};

// The niceness of a map's recognition threads: EVERY_FRAME (acks wait for recognition)
// at 0; NEWEST 10 steps below the map's ingestion threads, at most 19, so that mapping
// wins the cores and recognition takes what it leaves (docs/recognition.md, "Scheduling").
int RecognitionNice(bool every_frame, int ingest_nice);

class RecognitionQueue {
 public:
  struct Options {
    bool every_frame = false;
    int nice = 0;  // the threads' niceness (base/thread_pool.h SetThreadNice)
  };
  // Starts the threads. Each job taken is passed to `prepare`, then to `run` (then the
  // job's done is called).
  RecognitionQueue(const Options& options, std::function<void(RecognitionJob&)> prepare,
                   std::function<void(RecognitionJob&)> run);
  // Stops taking jobs, waits for the running ones, calls `done` of the pending ones.
  ~RecognitionQueue();
  RecognitionQueue(const RecognitionQueue&) = delete;
  RecognitionQueue& operator=(const RecognitionQueue&) = delete;

  void Offer(RecognitionJob job);
  // Jobs replaced before they ran (policy newest), before either step.
  uint64_t skipped() const { return skipped_.load(std::memory_order_relaxed); }
  // Returns once every job offered before the call has run both steps (tests, clean stops).
  void Flush();

 private:
  // The loop of step 0 (prepare) or step 1 (run).
  void Loop(int step);
  // Queues `job` before `step` by the policy (newest: it replaces a waiting job). Returns
  // the done to call outside the lock: the replaced job's, or the job's own when stopping.
  // REQUIRES: mu_ held.
  std::function<void()> EnqueueLocked(int step, RecognitionJob job);

  const Options options_;
  const std::function<void(RecognitionJob&)> prepare_, run_;
  std::atomic<uint64_t> skipped_{0};
  std::mutex mu_;
  std::condition_variable cv_;
  std::deque<RecognitionJob> jobs_[2];  // guarded by mu_: waiting for step 0 / step 1
  bool running_[2] = {false, false};    // guarded by mu_: a job is in step 0 / step 1
  bool stopping_ = false;               // guarded by mu_
  std::thread threads_[2];
};

}  // namespace skimap::server

#endif  // SERVER_CORE_RECOGNITION_RECOGNITION_QUEUE_H_
