// FleetNode: this skimapd as one node of a fleet on a shared store (storage/lease_store.h).
// It is the MapOwnership of the node's MapService: a map is served here only while this
// node holds its lease; a request for a map without a live owner takes the lease (the
// service then loads the map: latest snapshot + journal replay), and one for a map another
// live node owns answers a redirect to it. A background thread heartbeats every ttl / 3:
// it keeps the node registered with its address and renews its leases; the maps whose
// lease it lost are reported to OnLost.
//
//   FleetNode fleet(store, {.address = "10.0.0.7:50051", .lease_ttl = absl::Seconds(6)});
//   MapService service({..., .store = store, .ownership = &fleet});
//   fleet.Start();            // registered, leases renewed from here on
//   ...
//   fleet.Leave();            // after the last snapshot: other nodes take the maps at once
//
// Thread safety: thread safe.
#ifndef SERVER_CORE_FLEET_FLEET_NODE_H_
#define SERVER_CORE_FLEET_FLEET_NODE_H_

#include <functional>
#include <map>
#include <string>
#include <thread>

#include "absl/base/thread_annotations.h"
#include "absl/time/time.h"
#include "base/mutex.h"
#include "server/core/maps/map_ownership.h"
#include "skimap/v1/fleet.pb.h"
#include "storage/lease_store.h"

namespace skimap::server {

class FleetNode final : public MapOwnership {
 public:
  struct Options {
    std::string address;                          // host:port other nodes and clients reach
    absl::Duration lease_ttl = absl::Seconds(6);  // leases and heartbeats expire after this
  };
  // REQUIRES: `leases` (the node's store, opened with its node id) outlives this object.
  FleetNode(storage::LeaseStore* leases, const Options& options);
  ~FleetNode();  // stops the heartbeat thread (does not Leave)

  // Registers the node (one heartbeat, its error if the store cannot be reached) and
  // starts the heartbeat thread. REQUIRES: called once.
  absl::Status Start();
  // Stops heartbeating, then removes the node and lets its leases expire now.
  absl::Status Leave();

  // MapOwnership (map_ownership.h).
  absl::StatusOr<bool> Claim(const std::string& id) override;
  absl::StatusOr<std::map<std::string, Owner>> Owners() override;
  void OnLost(std::function<void(const std::string& id)> lost) override;

  // Every registered node and the maps each holds a live lease on (FleetService).
  absl::StatusOr<v1::ListNodesResponse> ListNodes();
  const std::string& node_id() const { return leases_->node_id(); }

 private:
  void HeartbeatLoop();
  void Lost(const std::string& id);
  // Records that map `id` is served here under `token`; true if it must be loaded anew
  // from the store: served under another token before (another node wrote it meanwhile),
  // or not served here yet unless `loaded` (created or imported here).
  bool Own(const std::string& id, int64_t token, bool loaded);
  void StopThread();

  storage::LeaseStore* const leases_;
  const Options options_;
  Mutex mu_;
  CondVar cv_;
  bool stopping_ ABSL_GUARDED_BY(mu_) = false;
  // Maps served here, with the fencing token of the lease they were loaded under.
  std::map<std::string, int64_t> owned_ ABSL_GUARDED_BY(mu_);
  std::function<void(const std::string&)> lost_;  // set before Start
  std::thread heartbeat_;
};

}  // namespace skimap::server

#endif  // SERVER_CORE_FLEET_FLEET_NODE_H_
