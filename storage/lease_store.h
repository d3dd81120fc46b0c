// LeaseStore: map ownership and membership for a fleet of skimapd nodes on one shared
// database (docs/architecture.md, "Fleet"). Like MapStore, it names no database type.
//
// A store that is also a LeaseStore is opened for one node (its id). A map's lease names
// the node that may write it and a fencing token; the node's writes to the map through its
// MapStore (AppendJournal, WriteSnapshot, PruneJournal, FinishImport, DeleteMap) check, in
// the same transaction, that the lease still names this node with the token it acquired,
// and otherwise change nothing and answer FailedPrecondition. CreateMap and BeginImport
// create the map with its lease held by the creating node.
//
//   std::optional<Held> held = leases.Held("kitchen");           // no database call
//   absl::StatusOr<Lease> lease = leases.AcquireLease("kitchen", absl::Seconds(6));
//   if (lease->node == leases.node_id()) { /* this node writes kitchen */ }
//   leases.Heartbeat("127.0.0.1:50051", ttl);  // membership + renews every held lease
//
// Expiry uses the database's clock only (nodes' clocks may differ); local validity (Held)
// is measured on this node's monotonic clock from the start of the last successful renewal,
// so it ends no later than the database's expiry.
//
// Thread safety: implementations are thread safe.
#ifndef SKIMAP_STORAGE_LEASE_STORE_H_
#define SKIMAP_STORAGE_LEASE_STORE_H_

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/time/time.h"

namespace skimap::storage {

// One map's lease as the database holds it.
struct Lease {
  std::string map;
  std::string node;     // holder's node id
  std::string address;  // holder's advertised address ("" if it never registered)
  int64_t token = 0;    // fencing token: grows by one each time the lease changes hands
  bool live = false;    // not expired (database clock)
};

// One registered node.
struct NodeInfo {
  std::string id;
  std::string address;
  int64_t started_unix_ms = 0;
  int64_t heartbeat_unix_ms = 0;  // database clock
  bool live = false;              // heartbeat within its ttl
};

class LeaseStore {
 public:
  // A lease this node holds: its token and until when (monotonic) it is surely valid.
  struct Held {
    int64_t token = 0;
    std::chrono::steady_clock::time_point valid_until;
  };

  virtual ~LeaseStore() = default;

  // This node's id (fixed at open).
  virtual const std::string& node_id() const = 0;

  // Registers or refreshes this node (address, heartbeat) and renews every lease it holds
  // for `ttl` from now (database clock), in one transaction. Returns the maps whose lease
  // it lost (taken by another node since): their fences are dropped, so writes to them
  // fail from now on. Unavailable if the database cannot be reached (nothing is renewed;
  // the held leases run out locally).
  virtual absl::StatusOr<std::vector<std::string>> Heartbeat(const std::string& address,
                                                             absl::Duration ttl) = 0;
  // Removes this node from the membership and lets every lease it holds expire now (a
  // clean shutdown: other nodes may take its maps at once). Fences are dropped.
  virtual absl::Status Leave() = 0;
  // Every registered node, by id; nodes not heard from for `forget_after` are deleted.
  virtual absl::StatusOr<std::vector<NodeInfo>> ListNodes(absl::Duration forget_after) = 0;

  // Takes the lease of map `id` for this node for `ttl` if no live node holds it (or this
  // node does: then it is renewed, token unchanged); returns the lease as it is after the
  // call: held by this node (its fence is set for the writes) or by the live holder.
  // NotFound if there is no map `id`.
  virtual absl::StatusOr<Lease> AcquireLease(const std::string& id, absl::Duration ttl) = 0;
  // The lease of map `id` if this node holds it and it is locally valid; no database call.
  virtual std::optional<Held> HeldLease(const std::string& id) = 0;
  // Every lease, ordered by map.
  virtual absl::StatusOr<std::vector<Lease>> ListLeases() = 0;
};

}  // namespace skimap::storage

#endif  // SKIMAP_STORAGE_LEASE_STORE_H_
