#include "base/thread_pool.h"

#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>

namespace skimap {

void SetThreadNice(int nice) {
  if (nice <= 0) return;
  // Best effort: a failure leaves the thread at the process's priority.
  (void)setpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid)), std::min(nice, 19));
}

ThreadPool::ThreadPool(int workers, int nice) : worker_count_(workers > 0 ? workers : 0) {
  for (size_t i = 0; i < worker_count_; ++i) {
    threads_.emplace_back([this, nice] {
      SetThreadNice(nice);
      WorkerLoop();
    });
  }
}

ThreadPool::~ThreadPool() {
  {
    MutexLock lock(&mu_);
    stop_ = true;
  }
  work_cv_.SignalAll();
  for (std::thread& t : threads_) t.join();
}

void ThreadPool::RunRanges(const std::function<void(size_t, size_t)>& fn, size_t n, size_t ranges) {
  for (;;) {
    const size_t r = next_.fetch_add(1, std::memory_order_relaxed);
    if (r >= ranges) return;
    fn(r * n / ranges, (r + 1) * n / ranges);
  }
}

void ThreadPool::ParallelFor(size_t n, const std::function<void(size_t, size_t)>& fn) {
  if (n == 0) return;
  if (worker_count_ == 0 || n == 1) {
    fn(0, n);
    return;
  }
  const size_t ranges = std::min(n, pieces());
  MutexLock call_lock(&call_mu_);
  {
    MutexLock lock(&mu_);
    fn_ = &fn;
    n_ = n;
    ranges_ = ranges;
    next_.store(0, std::memory_order_relaxed);
    ++generation_;
  }
  work_cv_.SignalAll();
  RunRanges(fn, n, ranges);
  // Every range is claimed; the ones still running belong to active workers. A worker
  // that wakes after this call ended finds fn_ null (or a later call) and never sees fn.
  MutexLock lock(&mu_);
  while (active_ != 0) done_cv_.Wait(&mu_);
  fn_ = nullptr;
}

void ThreadPool::WorkerLoop() {
  size_t seen = 0;
  for (;;) {
    const std::function<void(size_t, size_t)>* fn;
    size_t n, ranges;
    {
      MutexLock lock(&mu_);
      while (!stop_ && (fn_ == nullptr || generation_ == seen)) work_cv_.Wait(&mu_);
      if (stop_) return;
      seen = generation_;
      fn = fn_;
      n = n_;
      ranges = ranges_;
      ++active_;
    }
    RunRanges(*fn, n, ranges);
    {
      MutexLock lock(&mu_);
      if (--active_ == 0) done_cv_.Signal();
    }
  }
}

}  // namespace skimap
