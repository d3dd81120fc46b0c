// ThreadPool: a fixed set of worker threads for data-parallel loops.
//
//   ThreadPool pool(2);
//   pool.ParallelFor(n, [&](size_t begin, size_t end) { ... });  // blocks until done
//
// ParallelFor splits [0, n) into contiguous ranges that the workers and the calling thread
// claim one at a time until none is left, and returns when all are done: a thread that
// another process or a decoder keeps off a core gets fewer ranges instead of holding the
// rest back. Callers that cut their work into pieces cut pieces() of them. With 0 workers
// everything runs inline.
//
// Thread safety: ParallelFor may be called from several threads; calls are serialized.
#ifndef BASE_THREAD_POOL_H_
#define BASE_THREAD_POOL_H_

#include <atomic>
#include <cstddef>
#include <functional>
#include <thread>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "base/mutex.h"

namespace skimap {

// Sets the calling thread's niceness (Linux; clamped to 0..19). A server lowers the
// priority of its bulk work (ingestion) so that interactive work (queries) keeps its
// latency when the cores are saturated; no effect at 0 or on an idle machine.
void SetThreadNice(int nice);

class ThreadPool {
 public:
  // Starts `workers` threads (0 = run everything on the caller), each at `nice` (Linux
  // scheduling niceness, 0..19: above 0 they yield to other threads of the process when the
  // cores are busy; see SetThreadNice).
  explicit ThreadPool(int workers, int nice = 0);
  ~ThreadPool();
  ThreadPool(const ThreadPool&) = delete;
  ThreadPool& operator=(const ThreadPool&) = delete;

  int workers() const { return static_cast<int>(worker_count_); }
  // How many pieces a caller should cut a piece-wise job into (per-piece scratch, then the
  // pieces joined): a few per thread, so that the threads end together; 1 without workers.
  size_t pieces() const { return worker_count_ == 0 ? 1 : kRangesPerThread * (worker_count_ + 1); }

  // Runs fn(begin, end) over a partition of [0, n) into at most pieces() ranges, each on
  // one thread, concurrently.
  void ParallelFor(size_t n, const std::function<void(size_t, size_t)>& fn);

 private:
  static constexpr size_t kRangesPerThread = 4;

  void WorkerLoop();
  // Claims and runs ranges of the current call until none is left.
  void RunRanges(const std::function<void(size_t, size_t)>& fn, size_t n, size_t ranges);

  Mutex call_mu_ ABSL_ACQUIRED_BEFORE(mu_);  // serializes ParallelFor calls
  Mutex mu_;
  CondVar work_cv_;
  CondVar done_cv_;
  // The current call (null between calls): fn over [0, n_) in ranges_ ranges.
  const std::function<void(size_t, size_t)>* fn_ ABSL_GUARDED_BY(mu_) = nullptr;
  size_t n_ ABSL_GUARDED_BY(mu_) = 0;
  size_t ranges_ ABSL_GUARDED_BY(mu_) = 0;
  size_t generation_ ABSL_GUARDED_BY(mu_) = 0;
  size_t active_ ABSL_GUARDED_BY(mu_) = 0;  // workers inside RunRanges of the current call
  // The next unclaimed range of the current call; reset (under mu_) only when no worker is
  // inside RunRanges.
  std::atomic<size_t> next_{0};
  bool stop_ ABSL_GUARDED_BY(mu_) = false;
  const size_t worker_count_;
  std::vector<std::thread> threads_;
};

}  // namespace skimap

#endif  // BASE_THREAD_POOL_H_
