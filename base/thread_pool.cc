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
    threads_.emplace_back([this, i, nice] {
      SetThreadNice(nice);
      WorkerLoop(i);
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

void ThreadPool::ParallelFor(size_t n, const std::function<void(size_t, size_t)>& fn) {
  if (n == 0) return;
  const size_t pieces = worker_count_ + 1;
  if (worker_count_ == 0 || n == 1) {
    fn(0, n);
    return;
  }
  MutexLock call_lock(&call_mu_);
  {
    MutexLock lock(&mu_);
    fn_ = &fn;
    n_ = n;
    pending_ = worker_count_;
    ++generation_;
  }
  work_cv_.SignalAll();
  // The caller takes the last piece.
  fn((pieces - 1) * n / pieces, n);
  MutexLock lock(&mu_);
  while (pending_ != 0) done_cv_.Wait(&mu_);
  fn_ = nullptr;
}

void ThreadPool::WorkerLoop(size_t index) {
  size_t seen = 0;
  for (;;) {
    const std::function<void(size_t, size_t)>* fn;
    size_t n;
    {
      MutexLock lock(&mu_);
      while (!stop_ && generation_ == seen) work_cv_.Wait(&mu_);
      if (stop_) return;
      seen = generation_;
      fn = fn_;
      n = n_;
    }
    const size_t pieces = worker_count_ + 1;
    (*fn)(index * n / pieces, (index + 1) * n / pieces);
    {
      MutexLock lock(&mu_);
      if (--pending_ == 0) done_cv_.Signal();
    }
  }
}

}  // namespace skimap
