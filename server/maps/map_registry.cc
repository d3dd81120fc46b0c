#include "server/maps/map_registry.h"

#include "absl/strings/str_cat.h"

namespace skimap::server {

absl::StatusOr<std::shared_ptr<LiveMap>> MapRegistry::Create(const std::string& id,
                                                             const MapConfig& config) {
  WriterLock lock(&mu_);
  if (maps_.contains(id)) {
    return absl::AlreadyExistsError(absl::StrCat("map ", MapName(id), " already exists"));
  }
  if (maps_.size() >= options_.max_maps) {
    return absl::ResourceExhaustedError(
        absl::StrCat("at most ", options_.max_maps, " maps per server"));
  }
  LiveMap::Options options = options_.map_defaults;
  options.config = config;
  auto map = std::make_shared<LiveMap>(id, options);
  maps_.emplace(id, map);
  return map;
}

absl::StatusOr<std::shared_ptr<LiveMap>> MapRegistry::Get(const std::string& id) const {
  WriterLock lock(&mu_);
  auto it = maps_.find(id);
  if (it == maps_.end()) {
    return absl::NotFoundError(absl::StrCat("map ", MapName(id), " not found"));
  }
  return it->second;
}

std::vector<std::shared_ptr<LiveMap>> MapRegistry::List(const std::string& after,
                                                        size_t limit) const {
  std::vector<std::shared_ptr<LiveMap>> out;
  WriterLock lock(&mu_);
  for (auto it = maps_.upper_bound(after); it != maps_.end() && out.size() < limit; ++it) {
    out.push_back(it->second);
  }
  return out;
}

absl::Status MapRegistry::Delete(const std::string& id) {
  std::shared_ptr<LiveMap> doomed;
  {
    WriterLock lock(&mu_);
    auto it = maps_.find(id);
    if (it == maps_.end()) {
      return absl::NotFoundError(absl::StrCat("map ", MapName(id), " not found"));
    }
    doomed = std::move(it->second);
    maps_.erase(it);
  }
  doomed->MarkDeleted();
  return absl::OkStatus();  // `doomed` released outside the lock
}

}  // namespace skimap::server
