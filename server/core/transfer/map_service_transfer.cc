// MapService: export and import of whole maps (map_exporter.h, map_importer.h).
#include "absl/strings/str_cat.h"
#include "server/core/maps/map_service.h"

namespace skimap::server {
namespace {

absl::Status NoStore(const char* what) {
  return absl::FailedPreconditionError(
      absl::StrCat(what,
                   " needs a server that keeps maps on disk (skimapd --data_dir); this one "
                   "keeps them in memory only"));
}

}  // namespace

absl::StatusOr<std::unique_ptr<MapExporter>> MapService::ExportMap(
    const v1::ExportMapRequest& request) {
  if (options_.store == nullptr) return NoStore("ExportMap");
  absl::StatusOr<std::shared_ptr<LiveMap>> map = FindMap(request.name(), "name");
  if (!map.ok()) return map.status();
  return MapExporter::Start(*std::move(map), options_.store,
                            {.with_journal = request.with_journal()});
}

absl::StatusOr<std::unique_ptr<MapImporter>> MapService::ImportMap(const std::string& map_id) {
  if (options_.store == nullptr) return NoStore("ImportMap");
  if (!map_id.empty()) {
    if (absl::Status s = ValidateMapId(map_id, "map_id"); !s.ok()) return s;
  }
  return std::make_unique<MapImporter>(&registry_, options_.store, map_id);
}

absl::StatusOr<v1::Map> MapService::FinishImport(MapImporter& importer) {
  absl::StatusOr<std::shared_ptr<LiveMap>> map = importer.Finish();
  if (!map.ok()) return map.status();
  return Describe({.id = (*map)->id(), .config = (*map)->config(), .map = *map});
}

}  // namespace skimap::server
