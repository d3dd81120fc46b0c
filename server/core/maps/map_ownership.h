// MapOwnership: the hook through which MapService asks, before it touches a map, whether
// this server may serve it. A single server has none (every map is its own); a fleet node
// (server/core/fleet/fleet_node.h) answers from the map leases in the shared store.
//
//   absl::StatusOr<bool> fresh = ownership->Claim("kitchen");
//   if (!fresh.ok()) return fresh.status();  // NotFound, or Unavailable + MapRedirect
//   if (*fresh) { /* (re)load the map from the store: another node may have written it */ }
//
// Thread safety: implementations are thread safe.
#ifndef SERVER_CORE_MAPS_MAP_OWNERSHIP_H_
#define SERVER_CORE_MAPS_MAP_OWNERSHIP_H_

#include <functional>
#include <map>
#include <string>

#include "absl/status/statusor.h"

namespace skimap::server {

class MapOwnership {
 public:
  // Who writes a map, as listed.
  struct Owner {
    std::string node;
    std::string address;
    bool live = false;
    bool here = false;  // this node holds the lease
  };

  virtual ~MapOwnership() = default;

  // Makes sure this node may serve map `id`, taking its lease if no live node holds it.
  // true: the lease was just taken (the map must be loaded anew from the store); false:
  // this node held it already. Errors: NotFound (no map `id` in the store), Unavailable
  // carrying a MapRedirect (server/core/fleet/redirect.h) to the live owner, the store's error.
  virtual absl::StatusOr<bool> Claim(const std::string& id) = 0;
  // The holder of every map lease, by map id.
  virtual absl::StatusOr<std::map<std::string, Owner>> Owners() = 0;
  // `lost` runs (on a background thread, once per map) when this node loses the lease of
  // a map it held: its in-memory copy must stop serving. Set once, before serving.
  virtual void OnLost(std::function<void(const std::string& id)> lost) = 0;
};

}  // namespace skimap::server

#endif  // SERVER_CORE_MAPS_MAP_OWNERSHIP_H_
