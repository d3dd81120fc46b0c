// MapRegistry: every map of the service by id, loaded in memory or on disk only.
//
//   MapRegistry registry({.map_defaults = {.store = store}, .memory_budget_bytes = 8 << 30});
//   registry.AddStored("kitchen", config);             // known, loaded on first use
//   absl::StatusOr<std::shared_ptr<LiveMap>> m = registry.Get("kitchen");  // loads it
//   registry.Maintain();                                // snapshots, evicts beyond the budget
//
// Loading: a map registered by AddStored (or evicted) is loaded (snapshot + journal tail,
// LiveMap::Load) by the first Get that needs it; concurrent Gets wait for that one load. A
// map whose data is corrupt or from a newer server keeps answering that error (naming the
// map and the cause) until it is deleted; the other maps are not affected.
//
// Eviction: Maintain() snapshots maps with unsnapshotted journal records, then, while the
// loaded maps' memory exceeds memory_budget_bytes, evicts the least recently used loaded
// map except the most recent one and those being exported (LiveMap::snapshots_held): its
// new writes answer Unavailable (retry), the writes already running finish, a snapshot is
// written, and it leaves memory; the next Get loads it again. Nothing journaled is lost:
// whatever the snapshot does not cover is replayed.
//
// Imports: Reserve takes an id before the map exists (the store is being written), so that
// no Create of the same id can slip in and no Get can load a half-written map; the import
// then loads the map itself (LoadReserved) and Publishes it, or Releases the id.
//
// Thread safety: thread safe. Returned maps are shared: a map removed by Delete stays alive
// until its last user lets go, and its queued writes answer NotFound.
#ifndef SERVER_CORE_MAPS_MAP_REGISTRY_H_
#define SERVER_CORE_MAPS_MAP_REGISTRY_H_

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/status/statusor.h"
#include "base/rw_lock.h"
#include "server/core/maps/live_map.h"

namespace skimap::server {

class MapRegistry {
 public:
  struct Options {
    LiveMap::Options map_defaults;  // pool, queue capacity, store, retention
    size_t max_maps = 1000;
    uint64_t memory_budget_bytes = 0;  // loaded maps' memory; 0 = no limit
  };
  // One map as listed: `map` when loaded; otherwise its stats when it was evicted
  // (loaded = false) and the error of its last load, if any.
  struct Listed {
    std::string id;
    MapConfig config;
    std::shared_ptr<LiveMap> map;
    v1::MapStats last_stats;
    absl::Status error;
  };

  explicit MapRegistry(const Options& options) : options_(options) {}

  // Calls fn(map) for every loaded map (outside the registry's lock).
  void ForEachLoaded(const std::function<void(LiveMap&)>& fn) const;

  // A new empty map, loaded. AlreadyExists if `id` is taken; ResourceExhausted beyond
  // max_maps. REQUIRES: ValidateMapId(id) is OK.
  absl::StatusOr<std::shared_ptr<LiveMap>> Create(const std::string& id, const MapConfig& config);
  // Registers a map of the store without loading it. AlreadyExists / ResourceExhausted.
  absl::Status AddStored(const std::string& id, const MapConfig& config);
  // The loaded map `id`, loading it first if needed. NotFound if there is no map `id`;
  // the load's error (DataLoss, FailedPrecondition, Unavailable, ...) naming the map.
  absl::StatusOr<std::shared_ptr<LiveMap>> Get(const std::string& id);
  // Up to `limit` maps with id > `after`, ordered by id; none is loaded by listing.
  std::vector<Listed> List(const std::string& after, size_t limit) const;
  // Removes map `id` (NotFound if absent). Blocks until its queued writes are answered
  // (NotFound; a write already running finishes first).
  absl::Status Delete(const std::string& id);

  // Takes `id` for an import without making it a map: Create, AddStored and Reserve of it
  // answer AlreadyExists, it counts towards max_maps (ResourceExhausted), and Get, List and
  // Delete do not see it. REQUIRES: ValidateMapId(id) is OK.
  absl::Status Reserve(const std::string& id);
  // Loads map `id` from the store (LiveMap::Load), as a first Get would, without making it
  // visible. The load's error, naming the map. REQUIRES: `id` is reserved.
  absl::StatusOr<std::shared_ptr<LiveMap>> LoadReserved(const std::string& id,
                                                        const MapConfig& config) const;
  // Turns the reservation of `id` into a loaded map served by `map` (from LoadReserved).
  // REQUIRES: `id` is reserved.
  void Publish(const std::string& id, const MapConfig& config, std::shared_ptr<LiveMap> map);
  // Drops the reservation of `id` (no-op if it has none).
  void Release(const std::string& id);

  // Fleet nodes (map_ownership.h): drops the loaded copy of map `id`, if any, without a
  // snapshot (its queued writes answer Unavailable), and registers the map as stored with
  // `config`, to be loaded from the store by the next Get (another node may have written
  // it). Adds the map if it is not known here.
  void Reset(const std::string& id, const MapConfig& config);
  // Fleet nodes: drops the loaded copy of map `id` (as Reset, keeping its config); no-op
  // for a map not loaded or not known.
  void Unload(const std::string& id);

  // Snapshots every loaded map with journal records no snapshot covers (all of them when
  // `min_records` is 1) and evicts beyond the memory budget (see above). Errors are
  // reported on stderr and retried next time.
  void Maintain(uint64_t min_records = 1);
  // Bytes held by the loaded maps.
  uint64_t LoadedBytes() const;

 private:
  struct Entry {
    MapConfig config;
    std::shared_ptr<LiveMap> map;  // null while on disk only
    v1::MapStats last_stats;
    absl::Status error;  // a load failure that a retry cannot fix (DataLoss, ...)
    uint64_t last_used = 0;
    std::shared_ptr<std::mutex> load_mu = std::make_shared<std::mutex>();  // one load at a time
  };
  absl::Status CheckRoom(const std::string& id) const ABSL_SHARED_LOCKS_REQUIRED(mu_);
  std::shared_ptr<LiveMap> NewMap(const std::string& id, const MapConfig& config) const;
  void Evict(const std::string& id, std::shared_ptr<LiveMap> map);
  // Reset / Unload: replaces the entry of `id` (config kept when null) after dropping its
  // loaded copy; does nothing for an unknown id unless `config` is given.
  void Replace(const std::string& id, const MapConfig* config);

  const Options options_;
  mutable RwLock mu_;
  std::map<std::string, Entry> maps_ ABSL_GUARDED_BY(mu_);
  std::set<std::string> reserved_ ABSL_GUARDED_BY(mu_);  // ids of imports under way
  uint64_t clock_ ABSL_GUARDED_BY(mu_) = 0;              // LRU ticks
};

}  // namespace skimap::server

#endif  // SERVER_CORE_MAPS_MAP_REGISTRY_H_
