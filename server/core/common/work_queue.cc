#include "server/core/common/work_queue.h"

#include <algorithm>
#include <utility>

#include "base/thread_pool.h"
#include "server/core/logging/request_context.h"

namespace skimap::server {
namespace {

// The task, run under the submitting thread's request (logging/request_context.h), so the
// log lines of a call's work on a worker carry its request id.
std::function<void()> WithRequest(std::function<void()> task) {
  const std::shared_ptr<const RequestContext>& request = CurrentRequest();
  if (request == nullptr) return task;
  return [request, task = std::move(task)] {
    ScopedRequest scope(request);
    task();
  };
}

}  // namespace

WorkQueue::WorkQueue(const Options& options)
    : capacity_(options.capacity < 1 ? 1 : options.capacity) {
  for (int i = 0; i < std::max(1, options.threads); ++i) {
    threads_.emplace_back([this, nice = options.nice] {
      SetThreadNice(nice);
      Loop();
    });
  }
}

WorkQueue::~WorkQueue() {
  {
    MutexLock lock(&mu_);
    stopping_ = true;
  }
  cv_.SignalAll();
  for (std::thread& t : threads_) t.join();
}

bool WorkQueue::TrySubmit(std::function<void()> task) {
  return TrySubmit(std::move(task), nullptr, nullptr);
}

bool WorkQueue::TrySubmit(std::function<void()> task, const void* kind,
                          std::shared_ptr<void> item) {
  task = WithRequest(std::move(task));
  {
    MutexLock lock(&mu_);
    if (stopping_ || tasks_.size() >= capacity_) return false;
    tasks_.push_back({std::move(task), kind, std::move(item)});
  }
  cv_.Signal();
  return true;
}

bool WorkQueue::Submit(std::function<void()> task) {
  task = WithRequest(std::move(task));
  {
    MutexLock lock(&mu_);
    if (stopping_) return false;
    tasks_.push_back({std::move(task)});
  }
  cv_.Signal();
  return true;
}

size_t WorkQueue::pending() const {
  MutexLock lock(&mu_);
  return tasks_.size();
}

std::shared_ptr<void> WorkQueue::TakeNextItem(const void* kind) {
  MutexLock lock(&mu_);
  if (tasks_.empty() || kind == nullptr || tasks_.front().kind != kind) return nullptr;
  std::shared_ptr<void> item = std::move(tasks_.front().item);
  tasks_.pop_front();
  return item;
}

void WorkQueue::Loop() {
  for (;;) {
    std::function<void()> task;
    {
      MutexLock lock(&mu_);
      while (!stopping_ && tasks_.empty()) cv_.Wait(&mu_);
      if (tasks_.empty()) return;  // stopping and drained
      task = std::move(tasks_.front().run);
      tasks_.pop_front();
    }
    task();
  }
}

}  // namespace skimap::server
