// ThreadPool: a fixed set of worker threads for data-parallel loops.
//
//   ThreadPool pool(2);
//   pool.ParallelFor(n, [&](size_t begin, size_t end) { ... });  // blocks until done
//
// ParallelFor splits [0, n) into contiguous ranges, runs them on the workers and on the
// calling thread, and returns when all are done. With 0 workers everything runs inline.
//
// Thread safety: ParallelFor may be called from several threads; calls are serialized.
#ifndef BASE_THREAD_POOL_H_
#define BASE_THREAD_POOL_H_

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

  // Runs fn(begin, end) over a partition of [0, n) in at most workers()+1 pieces.
  void ParallelFor(size_t n, const std::function<void(size_t, size_t)>& fn);

 private:
  void WorkerLoop(size_t index);

  Mutex call_mu_ ABSL_ACQUIRED_BEFORE(mu_);  // serializes ParallelFor calls
  Mutex mu_;
  CondVar work_cv_;
  CondVar done_cv_;
  const std::function<void(size_t, size_t)>* fn_ ABSL_GUARDED_BY(mu_) = nullptr;
  size_t n_ ABSL_GUARDED_BY(mu_) = 0;
  size_t generation_ ABSL_GUARDED_BY(mu_) = 0;
  size_t pending_ ABSL_GUARDED_BY(mu_) = 0;
  bool stop_ ABSL_GUARDED_BY(mu_) = false;
  const size_t worker_count_;
  std::vector<std::thread> threads_;
};

}  // namespace skimap

#endif  // BASE_THREAD_POOL_H_
