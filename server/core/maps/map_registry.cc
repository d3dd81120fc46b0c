#include "server/core/maps/map_registry.h"

#include <algorithm>
#include <cstdio>

#include "absl/strings/str_cat.h"
#include "server/core/logging/log.h"

namespace skimap::server {
namespace {

absl::Status NoMap(const std::string& id) {
  return absl::NotFoundError(absl::StrCat("map ", MapName(id), " not found"));
}

// Load errors that a retry cannot fix stay with the map until it is deleted.
bool Permanent(const absl::Status& s) {
  return absl::IsDataLoss(s) || absl::IsFailedPrecondition(s) || absl::IsInvalidArgument(s);
}

uint64_t MemoryOf(const v1::MapStats& s) { return s.memory_bytes() + s.kept_frame_bytes(); }

}  // namespace

absl::Status MapRegistry::CheckRoom(const std::string& id) const {
  if (maps_.contains(id)) {
    return absl::AlreadyExistsError(absl::StrCat("map ", MapName(id), " already exists"));
  }
  if (reserved_.contains(id)) {
    return absl::AlreadyExistsError(
        absl::StrCat("map ", MapName(id), " already exists (an import of it is under way)"));
  }
  if (maps_.size() + reserved_.size() >= options_.max_maps) {
    return absl::ResourceExhaustedError(
        absl::StrCat("map ", MapName(id), " not created: the server holds ", maps_.size(),
                     " maps (and ", reserved_.size(), " imports), the limit is ", options_.max_maps,
                     " maps per server (skimapd --max_maps)"));
  }
  return absl::OkStatus();
}

std::shared_ptr<LiveMap> MapRegistry::NewMap(const std::string& id, const MapConfig& config) const {
  LiveMap::Options options = options_.map_defaults;
  options.config = config;
  return std::make_shared<LiveMap>(id, options);
}

void MapRegistry::ForEachLoaded(const std::function<void(LiveMap&)>& fn) const {
  std::vector<std::shared_ptr<LiveMap>> loaded;
  {
    ReaderLock lock(&mu_);
    for (const auto& [id, e] : maps_) {
      if (e.map != nullptr) loaded.push_back(e.map);
    }
  }
  for (const std::shared_ptr<LiveMap>& map : loaded) fn(*map);
}

absl::StatusOr<std::shared_ptr<LiveMap>> MapRegistry::Create(const std::string& id,
                                                             const MapConfig& config) {
  WriterLock lock(&mu_);
  if (absl::Status s = CheckRoom(id); !s.ok()) return s;
  std::shared_ptr<LiveMap> map = NewMap(id, config);
  maps_[id] = Entry{.config = config, .map = map, .last_used = ++clock_};
  return map;
}

absl::Status MapRegistry::AddStored(const std::string& id, const MapConfig& config) {
  WriterLock lock(&mu_);
  if (absl::Status s = CheckRoom(id); !s.ok()) return s;
  maps_[id] = Entry{.config = config};
  return absl::OkStatus();
}

absl::Status MapRegistry::Reserve(const std::string& id) {
  WriterLock lock(&mu_);
  if (absl::Status s = CheckRoom(id); !s.ok()) return s;
  reserved_.insert(id);
  return absl::OkStatus();
}

absl::StatusOr<std::shared_ptr<LiveMap>> MapRegistry::LoadReserved(const std::string& id,
                                                                   const MapConfig& config) const {
  std::shared_ptr<LiveMap> map = NewMap(id, config);
  if (absl::Status s = map->Load(); !s.ok()) {
    return absl::Status(s.code(),
                        absl::StrCat("map ", MapName(id), " cannot be loaded: ", s.message()));
  }
  return map;
}

void MapRegistry::Publish(const std::string& id, const MapConfig& config,
                          std::shared_ptr<LiveMap> map) {
  WriterLock lock(&mu_);
  reserved_.erase(id);
  maps_[id] = Entry{.config = config, .map = std::move(map), .last_used = ++clock_};
}

void MapRegistry::Release(const std::string& id) {
  WriterLock lock(&mu_);
  reserved_.erase(id);
}

absl::StatusOr<std::shared_ptr<LiveMap>> MapRegistry::Get(const std::string& id) {
  std::shared_ptr<std::mutex> load_mu;
  MapConfig config;
  {
    WriterLock lock(&mu_);
    auto it = maps_.find(id);
    if (it == maps_.end()) return NoMap(id);
    Entry& e = it->second;
    e.last_used = ++clock_;
    if (e.map != nullptr) return e.map;
    if (!e.error.ok()) return e.error;
    load_mu = e.load_mu;
    config = e.config;
  }
  std::lock_guard<std::mutex> one_load(*load_mu);
  {
    ReaderLock lock(&mu_);
    auto it = maps_.find(id);
    if (it == maps_.end()) return NoMap(id);
    if (it->second.map != nullptr) return it->second.map;  // loaded while we waited
  }
  std::shared_ptr<LiveMap> map = NewMap(id, config);
  absl::Status loaded = map->Load();
  if (!loaded.ok()) {
    loaded = absl::Status(
        loaded.code(), absl::StrCat("map ", MapName(id), " cannot be loaded: ", loaded.message()));
    LogError(loaded.ToString());
  }
  WriterLock lock(&mu_);
  auto it = maps_.find(id);
  if (it == maps_.end()) return NoMap(id);  // deleted while loading
  if (!loaded.ok()) {
    if (Permanent(loaded)) it->second.error = loaded;
    return loaded;
  }
  it->second.map = map;
  return map;
}

std::vector<MapRegistry::Listed> MapRegistry::List(const std::string& after, size_t limit) const {
  std::vector<Listed> out;
  ReaderLock lock(&mu_);
  for (auto it = maps_.upper_bound(after); it != maps_.end() && out.size() < limit; ++it) {
    const Entry& e = it->second;
    out.push_back({it->first, e.config, e.map, e.last_stats, e.error});
  }
  return out;
}

absl::Status MapRegistry::Delete(const std::string& id) {
  std::shared_ptr<std::mutex> load_mu;
  {
    ReaderLock lock(&mu_);
    auto it = maps_.find(id);
    if (it == maps_.end()) return NoMap(id);
    load_mu = it->second.load_mu;
  }
  // Not while the map loads or leaves memory: its snapshot must not reach a new map
  // created under the same id.
  std::lock_guard<std::mutex> no_load(*load_mu);
  std::shared_ptr<LiveMap> doomed;
  {
    WriterLock lock(&mu_);
    auto it = maps_.find(id);
    if (it == maps_.end()) return NoMap(id);
    doomed = std::move(it->second.map);
    maps_.erase(it);
  }
  if (doomed != nullptr) {
    // Writes already past their check finish before the caller deletes the map's data:
    // none can then reach a new map created under the same id.
    doomed->MarkDeleted();
    doomed->Drain();
  }
  return absl::OkStatus();  // `doomed` released outside the lock
}

void MapRegistry::Reset(const std::string& id, const MapConfig& config) { Replace(id, &config); }

void MapRegistry::Unload(const std::string& id) { Replace(id, nullptr); }

void MapRegistry::Replace(const std::string& id, const MapConfig* config) {
  std::shared_ptr<std::mutex> load_mu;
  {
    WriterLock lock(&mu_);
    auto it = maps_.find(id);
    if (it == maps_.end()) {
      if (config != nullptr) maps_[id] = Entry{.config = *config};
      return;
    }
    load_mu = it->second.load_mu;
  }
  std::lock_guard<std::mutex> no_load(*load_mu);  // not while it loads or leaves memory
  std::shared_ptr<LiveMap> dropped;
  {
    WriterLock lock(&mu_);
    auto it = maps_.find(id);
    if (it == maps_.end()) {
      if (config != nullptr) maps_[id] = Entry{.config = *config};
      return;
    }
    dropped = std::move(it->second.map);
    it->second.error = absl::OkStatus();
    if (config != nullptr) it->second.config = *config;
  }
  if (dropped != nullptr) {
    dropped->MarkEvicted();  // no snapshot: the store refuses this node's writes anyway
    dropped->Drain();
  }
}

uint64_t MapRegistry::LoadedBytes() const {
  uint64_t total = 0;
  ReaderLock lock(&mu_);
  for (const auto& [id, e] : maps_) {
    if (e.map != nullptr) total += MemoryOf(e.map->Stats());
  }
  return total;
}

void MapRegistry::Maintain(uint64_t min_records) {
  struct Loaded {
    std::string id;
    std::shared_ptr<LiveMap> map;
    uint64_t last_used;
    uint64_t bytes;
  };
  std::vector<Loaded> loaded;
  {
    ReaderLock lock(&mu_);
    for (const auto& [id, e] : maps_) {
      if (e.map != nullptr) loaded.push_back({id, e.map, e.last_used, 0});
    }
  }
  uint64_t total = 0;
  for (Loaded& m : loaded) {
    if (m.map->records_since_snapshot() >= min_records) {
      if (absl::Status s = m.map->Snapshot(); !s.ok()) {
        LogError(s.ToString());
      }
    }
  }
  if (options_.memory_budget_bytes == 0 || options_.map_defaults.store == nullptr) return;
  for (Loaded& m : loaded) {
    m.bytes = MemoryOf(m.map->Stats());
    total += m.bytes;
  }
  std::sort(loaded.begin(), loaded.end(),
            [](const Loaded& a, const Loaded& b) { return a.last_used < b.last_used; });
  // The most recently used map stays: evicting it would only load it again.
  for (size_t i = 0; i + 1 < loaded.size() && total > options_.memory_budget_bytes; ++i) {
    // An export reads the store as its snapshot left it: a reload could snapshot anew.
    if (loaded[i].map->snapshots_held()) continue;
    Evict(loaded[i].id, loaded[i].map);
    total -= loaded[i].bytes;
  }
}

void MapRegistry::Evict(const std::string& id, std::shared_ptr<LiveMap> map) {
  // Unpublish first, holding the map's load mutex: a Get from now on waits for the
  // eviction to finish and then loads the map again; only writes that found the map
  // before answer Unavailable.
  std::shared_ptr<std::mutex> load_mu;
  {
    WriterLock lock(&mu_);
    auto it = maps_.find(id);
    if (it == maps_.end() || it->second.map != map) return;
    load_mu = it->second.load_mu;
  }
  std::lock_guard<std::mutex> no_load(*load_mu);
  {
    WriterLock lock(&mu_);
    auto it = maps_.find(id);
    if (it == maps_.end() || it->second.map != map) return;
    it->second.map = nullptr;
  }
  map->MarkEvicted();  // new writes: Unavailable; running ones finish in Drain
  map->Drain();
  absl::Status s = map->Snapshot();
  v1::MapStats stats = map->Stats();
  stats.set_loaded(false);
  WriterLock lock(&mu_);
  auto it = maps_.find(id);
  if (it == maps_.end()) return;  // deleted meanwhile
  if (!s.ok()) {
    // Keep it: a reload would have to replay what the snapshot missed from a failing store.
    map->MarkEvicted(false);
    it->second.map = map;
    LogWarning(absl::StrCat("map ", MapName(id), " not evicted: ", s.ToString()));
    return;
  }
  it->second.last_stats = std::move(stats);
}

}  // namespace skimap::server
