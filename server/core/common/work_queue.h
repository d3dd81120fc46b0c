// WorkQueue: worker threads running tasks from a bounded queue, started in submission
// order. With one thread (the default) tasks run one at a time, in order: a map's writes.
// With more, up to `threads` run at once: the gRPC adapter's blocking steps (export,
// import), kept off gRPC's callback threads.
//
//   WorkQueue queue({.capacity = 64});
//   if (!queue.TrySubmit([] { ... })) { /* full: tell the client RESOURCE_EXHAUSTED */ }
//
// A task runs under the request (logging/request_context.h) current where it was submitted.
//
// A task may carry an item of a kind (any address naming it): a single-thread queue's task
// can then take the items queued right behind it (TakeNextItem), so that a map's worker
// handles the frames waiting behind a frame as one group (one durable journal append).
//
// The destructor stops accepting tasks, runs every task already queued, then joins.
//
// Thread safety: TrySubmit may be called from any thread, except from a task of the same
// queue's destructor path (a task must not destroy its own queue).
#ifndef SERVER_CORE_COMMON_WORK_QUEUE_H_
#define SERVER_CORE_COMMON_WORK_QUEUE_H_

#include <cstddef>
#include <cstdlib>
#include <deque>
#include <functional>
#include <future>
#include <memory>
#include <thread>
#include <vector>

#include "base/mutex.h"

namespace skimap::server {

class WorkQueue {
 public:
  struct Options {
    size_t capacity = 64;  // queued (not yet running) tasks, >= 1
    int threads = 1;       // worker threads, >= 1
    int nice = 0;          // their niceness (SetThreadNice): > 0 for bulk work
  };
  explicit WorkQueue(const Options& options);
  ~WorkQueue();
  WorkQueue(const WorkQueue&) = delete;
  WorkQueue& operator=(const WorkQueue&) = delete;

  // Queues `task`; false (and `task` dropped) when the queue is full or shutting down.
  [[nodiscard]] bool TrySubmit(std::function<void()> task);
  // The same for a task carrying `item` of `kind` (TakeNextItem).
  [[nodiscard]] bool TrySubmit(std::function<void()> task, const void* kind,
                               std::shared_ptr<void> item);
  // Queues `task` past the capacity (the server's own bounded work: snapshot captures,
  // journal replay); false only while shutting down.
  [[nodiscard]] bool Submit(std::function<void()> task);
  // Runs fn() on a worker after the tasks queued before it started and returns its result
  // (REQUIRES: not called from a worker; the queue is not shutting down).
  template <class Fn>
  auto Run(Fn&& fn) -> decltype(fn());
  // Tasks queued and not yet started.
  size_t pending() const;
  // When the next queued task carries an item of `kind`: removes that task without running
  // it and returns its item (whoever calls this does the task's work). Null otherwise.
  std::shared_ptr<void> TakeNextItem(const void* kind);

 private:
  struct Task {
    std::function<void()> run;
    const void* kind = nullptr;
    std::shared_ptr<void> item;
  };
  void Loop();

  const size_t capacity_;
  // skimap::Mutex (std::mutex), not absl::Mutex: Debian's Abseil is not TSan-instrumented.
  mutable Mutex mu_;
  CondVar cv_;
  std::deque<Task> tasks_ ABSL_GUARDED_BY(mu_);
  bool stopping_ ABSL_GUARDED_BY(mu_) = false;
  std::vector<std::thread> threads_;
};

template <class Fn>
auto WorkQueue::Run(Fn&& fn) -> decltype(fn()) {
  std::packaged_task<decltype(fn())()> task(std::forward<Fn>(fn));
  auto result = task.get_future();
  auto shared = std::make_shared<decltype(task)>(std::move(task));
  if (!Submit([shared] { (*shared)(); })) std::abort();  // REQUIRES violated
  return result.get();
}

}  // namespace skimap::server

#endif  // SERVER_CORE_COMMON_WORK_QUEUE_H_
