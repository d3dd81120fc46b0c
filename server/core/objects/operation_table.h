// OperationTable: the long-running operations of the object service ("operations/{id}"):
// progress while they run, the outcome when done, and waiters that are answered when an
// operation finishes or their timeout passes — without blocking a thread per waiter (one
// timer thread serves every timeout).
//
//   std::string name = table.Start("BuildClassifier");
//   table.SetProgress(name, progress);                  // from the worker
//   table.Finish(name, status, [](v1::Operation* op) { *op->mutable_classifier() = ...; });
//   table.Wait(name, absl::Seconds(10), [](absl::StatusOr<v1::Operation> op) { ... });
//
// Finished operations are kept (the newest `max_finished`) until the table is destroyed.
// Thread safety: thread safe. Callbacks (Wait's `done`) run without the table's lock held,
// on the thread that finishes the operation, the timer thread, or the caller of Wait.
#ifndef SERVER_CORE_OBJECTS_OPERATION_TABLE_H_
#define SERVER_CORE_OBJECTS_OPERATION_TABLE_H_

#include <chrono>
#include <deque>
#include <functional>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "base/mutex.h"
#include "skimap/v1/objects.pb.h"

namespace skimap::server {

class OperationTable {
 public:
  struct Options {
    size_t max_finished = 100;  // finished operations kept for Get/Wait
  };
  using WaitDone = std::function<void(absl::StatusOr<v1::Operation>)>;

  explicit OperationTable(const Options& options);
  // Answers every pending waiter with the operation as it is, then joins the timer thread.
  ~OperationTable();
  OperationTable(const OperationTable&) = delete;
  OperationTable& operator=(const OperationTable&) = delete;

  // Registers a running operation of `kind`; returns its name.
  std::string Start(const std::string& kind);
  // Progress of a running operation (ignored once done).
  void SetProgress(const std::string& name, const v1::OperationProgress& progress);
  // Marks it done with `status`; on OK, `fill_result` (may be null) sets the result.
  // Answers its waiters.
  void Finish(const std::string& name, const absl::Status& status,
              const std::function<void(v1::Operation*)>& fill_result);

  // The operation; InvalidArgument for a malformed name, NotFound for an unknown one.
  absl::StatusOr<v1::Operation> Get(const std::string& name) const;
  // Calls done(operation) once it is done or after `timeout` (done with the running
  // operation), whichever is first; done(error) at once for an unknown name.
  void Wait(const std::string& name, absl::Duration timeout, WaitDone done);

 private:
  struct Entry {
    v1::Operation op;
    absl::Time start;
  };
  struct Waiter {
    std::string name;
    std::chrono::steady_clock::time_point deadline;
    WaitDone done;
  };
  v1::Operation Snapshot(const Entry& e) const ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  void TimerLoop();

  const Options options_;
  mutable Mutex mu_;
  CondVar cv_;
  uint64_t next_id_ ABSL_GUARDED_BY(mu_) = 1;
  std::map<std::string, Entry> ops_ ABSL_GUARDED_BY(mu_);
  std::deque<std::string> finished_ ABSL_GUARDED_BY(mu_);  // oldest first
  std::vector<Waiter> waiters_ ABSL_GUARDED_BY(mu_);
  bool stopping_ ABSL_GUARDED_BY(mu_) = false;
  std::thread timer_;
};

}  // namespace skimap::server

#endif  // SERVER_CORE_OBJECTS_OPERATION_TABLE_H_
