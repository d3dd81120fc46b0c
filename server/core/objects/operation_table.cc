#include "server/core/objects/operation_table.h"

#include <algorithm>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "base/echo.h"

namespace skimap::server {

OperationTable::OperationTable(const Options& options)
    : options_(options), timer_([this] { TimerLoop(); }) {}

OperationTable::~OperationTable() {
  std::vector<std::pair<WaitDone, v1::Operation>> answers;
  {
    MutexLock lock(&mu_);
    stopping_ = true;
    for (Waiter& w : waiters_) answers.emplace_back(std::move(w.done), Snapshot(ops_.at(w.name)));
    waiters_.clear();
  }
  cv_.SignalAll();
  timer_.join();
  for (auto& [done, op] : answers) done(std::move(op));
}

std::string OperationTable::Start(const std::string& kind) {
  MutexLock lock(&mu_);
  const std::string name = absl::StrCat("operations/", next_id_++);
  Entry& e = ops_[name];
  e.start = absl::Now();
  e.op.set_name(name);
  e.op.set_kind(kind);
  e.op.mutable_create_time()->set_seconds(absl::ToUnixSeconds(e.start));
  e.op.mutable_progress()->set_stage("queued");
  return name;
}

void OperationTable::SetProgress(const std::string& name, const v1::OperationProgress& progress) {
  MutexLock lock(&mu_);
  auto it = ops_.find(name);
  if (it != ops_.end() && !it->second.op.done()) *it->second.op.mutable_progress() = progress;
}

void OperationTable::Finish(const std::string& name, const absl::Status& status,
                            const std::function<void(v1::Operation*)>& fill_result) {
  std::vector<std::pair<WaitDone, v1::Operation>> answers;
  {
    MutexLock lock(&mu_);
    auto it = ops_.find(name);
    if (it == ops_.end() || it->second.op.done()) return;
    Entry& e = it->second;
    e.op.set_done(true);
    e.op.set_code(static_cast<int>(status.code()));
    e.op.set_message(std::string(status.message()));
    const absl::Duration elapsed = absl::Now() - e.start;
    e.op.mutable_elapsed()->set_seconds(absl::ToInt64Seconds(elapsed));
    e.op.mutable_elapsed()->set_nanos(
        static_cast<int32_t>(absl::ToInt64Nanoseconds(elapsed % absl::Seconds(1))));
    if (status.ok()) {
      e.op.mutable_progress()->set_fraction(1);
      if (fill_result) fill_result(&e.op);
    }
    const v1::Operation snapshot = Snapshot(e);
    auto waiting = std::stable_partition(waiters_.begin(), waiters_.end(),
                                         [&](const Waiter& w) { return w.name != name; });
    for (auto w = waiting; w != waiters_.end(); ++w)
      answers.emplace_back(std::move(w->done), snapshot);
    waiters_.erase(waiting, waiters_.end());
    finished_.push_back(name);
    while (finished_.size() > options_.max_finished) {
      const std::string& oldest = finished_.front();
      const bool waited = std::any_of(waiters_.begin(), waiters_.end(),
                                      [&](const Waiter& w) { return w.name == oldest; });
      if (waited) break;  // cannot happen (waiters of finished ops were answered); be safe
      ops_.erase(finished_.front());
      finished_.pop_front();
    }
  }
  for (auto& [done, op] : answers) done(std::move(op));
}

v1::Operation OperationTable::Snapshot(const Entry& e) const {
  v1::Operation op = e.op;
  if (!op.done()) {
    const absl::Duration elapsed = absl::Now() - e.start;
    op.mutable_elapsed()->set_seconds(absl::ToInt64Seconds(elapsed));
    op.mutable_elapsed()->set_nanos(
        static_cast<int32_t>(absl::ToInt64Nanoseconds(elapsed % absl::Seconds(1))));
  }
  return op;
}

absl::StatusOr<v1::Operation> OperationTable::Get(const std::string& name) const {
  if (!absl::StartsWith(name, "operations/")) {
    return absl::InvalidArgumentError(
        absl::StrCat("name: ", Echo(name), " is not an operation name operations/{id}"));
  }
  MutexLock lock(&mu_);
  auto it = ops_.find(name);
  if (it == ops_.end())
    return absl::NotFoundError(absl::StrCat("operation ", Echo(name), " not found"));
  return Snapshot(it->second);
}

void OperationTable::Wait(const std::string& name, absl::Duration timeout, WaitDone done) {
  absl::StatusOr<v1::Operation> now;
  {
    MutexLock lock(&mu_);
    auto it = ops_.find(name);
    if (it != ops_.end() && !it->second.op.done() && !stopping_ && timeout > absl::ZeroDuration()) {
      waiters_.push_back({name,
                          std::chrono::steady_clock::now() + absl::ToChronoNanoseconds(timeout),
                          std::move(done)});
      cv_.SignalAll();
      return;
    }
  }
  done(Get(name));
}

void OperationTable::TimerLoop() {
  MutexLock lock(&mu_);
  while (!stopping_) {
    auto next = std::chrono::steady_clock::time_point::max();
    for (const Waiter& w : waiters_) next = std::min(next, w.deadline);
    if (next == std::chrono::steady_clock::time_point::max()) {
      cv_.Wait(&mu_);
    } else {
      cv_.WaitUntil(&mu_, next);
    }
    const auto now = std::chrono::steady_clock::now();
    std::vector<std::pair<WaitDone, v1::Operation>> answers;
    auto expired = std::stable_partition(waiters_.begin(), waiters_.end(),
                                         [&](const Waiter& w) { return w.deadline > now; });
    for (auto w = expired; w != waiters_.end(); ++w) {
      answers.emplace_back(std::move(w->done), Snapshot(ops_.at(w->name)));
    }
    waiters_.erase(expired, waiters_.end());
    if (answers.empty()) continue;
    lock.Unlock();
    for (auto& [done, op] : answers) done(std::move(op));
    lock.Lock();
  }
}

}  // namespace skimap::server
