// MapRegistry: the live maps of the service by id.
//
// Thread safety: thread safe. Returned maps are shared: a map removed by Delete stays
// alive until its last user lets go, and its queued writes answer NotFound.
#ifndef SERVER_MAPS_MAP_REGISTRY_H_
#define SERVER_MAPS_MAP_REGISTRY_H_

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/status/statusor.h"
#include "server/maps/live_map.h"
#include "skimap/rw_lock.h"

namespace skimap::server {

class MapRegistry {
 public:
  struct Options {
    LiveMap::Options map_defaults;  // pool, queue capacity, kept-frame budget
    size_t max_maps = 1000;
  };
  explicit MapRegistry(const Options& options) : options_(options) {}

  // AlreadyExists if `id` is taken; ResourceExhausted beyond max_maps.
  // REQUIRES: ValidateMapId(id) is OK.
  absl::StatusOr<std::shared_ptr<LiveMap>> Create(const std::string& id, const MapConfig& config);
  // NotFound if there is no map `id`.
  absl::StatusOr<std::shared_ptr<LiveMap>> Get(const std::string& id) const;
  // Up to `limit` maps with id > `after`, ordered by id.
  std::vector<std::shared_ptr<LiveMap>> List(const std::string& after, size_t limit) const;
  // Removes map `id` (NotFound if absent). Blocks until its queued writes are answered
  // when this was the last reference.
  absl::Status Delete(const std::string& id);

 private:
  const Options options_;
  mutable RwLock mu_;
  std::map<std::string, std::shared_ptr<LiveMap>> maps_ ABSL_GUARDED_BY(mu_);
};

}  // namespace skimap::server

#endif  // SERVER_MAPS_MAP_REGISTRY_H_
