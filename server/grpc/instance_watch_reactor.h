// InstanceWatchReactor: the gRPC side of WatchInstances (server stream of InstanceEvent).
// It writes the events InstanceQueries::InstanceWatch gives, one write at a time; when there
// is none it waits for the map's wake-up (new events, or the map deleted / unloaded, which
// ends the call with NOT_FOUND). Never holds its mutex while gRPC could call back into it
// synchronously: StartWrite and Finish only queue work.
//
// Thread safety: OnWriteDone / OnCancel (gRPC threads) and the wake-up (a map's worker)
// may race; a mutex orders them.
#ifndef SERVER_GRPC_INSTANCE_WATCH_REACTOR_H_
#define SERVER_GRPC_INSTANCE_WATCH_REACTOR_H_

#include <grpcpp/grpcpp.h>

#include <deque>
#include <memory>
#include <mutex>

#include "server/core/recognition/instance_queries.h"
#include "skimap/v1/instances.pb.h"

namespace skimap::server {

class InstanceWatchReactor final : public grpc::ServerWriteReactor<v1::InstanceEvent> {
 public:
  // REQUIRES: `instances` outlives the call. Deletes itself in OnDone.
  InstanceWatchReactor(const InstanceQueries* instances, const v1::WatchInstancesRequest& request);
  void OnWriteDone(bool ok) override;
  void OnCancel() override;
  void OnDone() override;

 private:
  void Wake();
  // With mu_ held: writes the next event if no write is in flight, fetching more when
  // none is pending; finishes on an error.
  void PumpLocked();
  void FinishLocked(const grpc::Status& status);

  std::mutex mu_;
  std::unique_ptr<InstanceQueries::InstanceWatch> watch_;  // guarded by mu_ (reset in OnDone)
  std::deque<v1::InstanceEvent> pending_;                  // guarded by mu_
  v1::InstanceEvent writing_event_;                        // guarded by mu_
  bool writing_ = false;                                   // guarded by mu_
  bool finished_ = false;                                  // guarded by mu_
  bool cancelled_ = false;                                 // guarded by mu_
};

}  // namespace skimap::server

#endif  // SERVER_GRPC_INSTANCE_WATCH_REACTOR_H_
