#include "server/grpc/instance_watch_reactor.h"

#include <utility>

#include "server/grpc/grpc_status.h"

namespace skimap::server {
namespace {

constexpr size_t kBatch = 64;  // events fetched from the map at a time

}  // namespace

InstanceWatchReactor::InstanceWatchReactor(const InstanceQueries* instances,
                                           const v1::WatchInstancesRequest& request) {
  absl::StatusOr<std::unique_ptr<InstanceQueries::InstanceWatch>> watch =
      instances->WatchInstances(request, [this] { Wake(); });
  std::lock_guard<std::mutex> lock(mu_);
  if (!watch.ok()) {
    FinishLocked(ToGrpcStatus(watch.status()));
    return;
  }
  watch_ = *std::move(watch);
  PumpLocked();
}

void InstanceWatchReactor::Wake() {
  std::lock_guard<std::mutex> lock(mu_);
  PumpLocked();
}

void InstanceWatchReactor::PumpLocked() {
  if (finished_ || writing_ || watch_ == nullptr) return;
  if (cancelled_) return FinishLocked(grpc::Status::CANCELLED);
  if (pending_.empty()) {
    absl::StatusOr<std::vector<v1::InstanceEvent>> events = watch_->Next(kBatch);
    if (!events.ok()) return FinishLocked(ToGrpcStatus(events.status()));
    for (v1::InstanceEvent& e : *events) pending_.push_back(std::move(e));
    if (pending_.empty()) return;  // woken again when events come
  }
  writing_event_ = std::move(pending_.front());
  pending_.pop_front();
  writing_ = true;
  StartWrite(&writing_event_);
}

void InstanceWatchReactor::FinishLocked(const grpc::Status& status) {
  if (finished_) return;
  finished_ = true;
  Finish(status);
}

void InstanceWatchReactor::OnWriteDone(bool ok) {
  std::lock_guard<std::mutex> lock(mu_);
  writing_ = false;
  if (!ok) return FinishLocked(grpc::Status(grpc::StatusCode::CANCELLED, "client went away"));
  PumpLocked();
}

void InstanceWatchReactor::OnCancel() {
  std::lock_guard<std::mutex> lock(mu_);
  cancelled_ = true;
  if (!writing_) FinishLocked(grpc::Status::CANCELLED);  // else when the write completes
}

void InstanceWatchReactor::OnDone() {
  std::unique_ptr<InstanceQueries::InstanceWatch> watch;
  {
    std::lock_guard<std::mutex> lock(mu_);
    watch = std::move(watch_);
  }
  watch.reset();  // no wake-up runs after this
  delete this;
}

}  // namespace skimap::server
