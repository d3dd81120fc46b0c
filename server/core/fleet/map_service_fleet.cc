// MapService: the hooks of a fleet node (Options::ownership; server/core/fleet/fleet_node.h).
#include <cstdio>
#include <set>

#include "absl/strings/str_cat.h"
#include "server/core/logging/log.h"
#include "server/core/maps/map_service.h"

namespace skimap::server {

absl::Status MapService::ClaimMap(const std::string& id) const {
  if (options_.ownership == nullptr) return absl::OkStatus();
  absl::StatusOr<bool> fresh = options_.ownership->Claim(id);
  if (absl::IsNotFound(fresh.status())) {
    (void)registry_.Delete(id);  // deleted by another node: forget it here too
    return absl::NotFoundError(absl::StrCat("map ", MapName(id), " not found"));
  }
  if (!fresh.ok() || !*fresh) return fresh.status();
  // The lease was just taken: the store holds the map as its last owner left it.
  absl::StatusOr<storage::StoredMap> stored = options_.store->GetMap(id);
  if (!stored.ok()) return stored.status();
  if (stored->importing) {
    // An import whose node died before it finished: it never became a map.
    LogWarning(absl::StrCat("map ", MapName(id), ": removing an import that did not finish"));
    (void)options_.store->DeleteMap(id);
    (void)registry_.Delete(id);
    return absl::NotFoundError(absl::StrCat("map ", MapName(id), " not found"));
  }
  v1::MapOptions proto;
  if (!proto.ParseFromString(stored->options)) {
    return absl::DataLossError(absl::StrCat("map ", MapName(id), ": stored options do not parse"));
  }
  absl::StatusOr<MapConfig> config = ResolveStoredMapOptions(proto);
  if (!config.ok()) return config.status();
  registry_.Reset(id, *config);  // loaded by the caller's Get: snapshot + journal replay
  return absl::OkStatus();
}

void MapService::SyncWithStore() const {
  absl::StatusOr<std::vector<storage::StoredMap>> stored = options_.store->ListMaps();
  if (!stored.ok()) return;  // the listing shows what is known here
  std::set<std::string> ids;
  for (const storage::StoredMap& m : *stored) {
    if (m.importing) continue;
    ids.insert(m.id);
    v1::MapOptions proto;
    if (!proto.ParseFromString(m.options)) continue;
    absl::StatusOr<MapConfig> config = ResolveStoredMapOptions(proto);
    if (config.ok()) (void)registry_.AddStored(m.id, *config);  // AlreadyExists if known
  }
  // Loaded maps stay: this node holds their lease (a map deleted elsewhere took its lease
  // with it, and the lost lease unloads the copy here).
  for (const MapRegistry::Listed& m : registry_.List("", SIZE_MAX)) {
    if (!ids.contains(m.id) && m.map == nullptr) (void)registry_.Delete(m.id);
  }
}

std::map<std::string, MapOwnership::Owner> MapService::Owners() const {
  if (options_.ownership == nullptr) return {};
  absl::StatusOr<std::map<std::string, MapOwnership::Owner>> owners = options_.ownership->Owners();
  return owners.ok() ? *std::move(owners) : std::map<std::string, MapOwnership::Owner>{};
}

}  // namespace skimap::server
