#include "server/core/transfer/map_transfer.h"

#include "absl/strings/str_cat.h"

namespace skimap::server {
namespace {

absl::Status NoStore(const char* what) {
  return absl::FailedPreconditionError(
      absl::StrCat(what,
                   " needs a server that keeps maps on disk (skimapd --data_dir); this one "
                   "keeps them in memory only"));
}

}  // namespace

absl::StatusOr<std::unique_ptr<MapExporter>> MapTransfer::Export(
    const v1::ExportMapRequest& request) const {
  if (maps_->store() == nullptr) return NoStore("ExportMap");
  absl::StatusOr<std::shared_ptr<LiveMap>> map = maps_->FindMap(request.name(), "name");
  if (!map.ok()) return map.status();
  return MapExporter::Start(*std::move(map), maps_->store(),
                            {.with_journal = request.with_journal()});
}

absl::StatusOr<std::unique_ptr<MapImporter>> MapTransfer::Import(const std::string& map_id) const {
  if (maps_->store() == nullptr) return NoStore("ImportMap");
  if (!map_id.empty()) {
    if (absl::Status s = ValidateMapId(map_id, "map_id"); !s.ok()) return s;
  }
  return std::make_unique<MapImporter>(maps_->registry(), maps_->store(), map_id);
}

absl::StatusOr<v1::Map> MapTransfer::Finish(MapImporter& importer) const {
  absl::StatusOr<std::shared_ptr<LiveMap>> map = importer.Finish();
  if (!map.ok()) return map.status();
  v1::Map out;
  out.set_name(MapName((*map)->id()));
  *out.mutable_options() = ToProto((*map)->config());
  *out.mutable_stats() = (*map)->Stats();
  return out;
}

}  // namespace skimap::server
