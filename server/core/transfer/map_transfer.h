// MapTransfer: export and import of whole maps over a MapService's maps and store (the
// API's ExportMap and ImportMap; the file format is docs/formats.md). Export snapshots the
// map and answers its export file piece by piece (map_exporter.h); an import is fed the
// file (MapImporter::Add) and ends with Finish, which loads the map as a restart would and
// answers it. The gRPC adapter holds one over the service it serves.
//
//   MapTransfer transfer(&maps);
//   absl::StatusOr<std::unique_ptr<MapExporter>> exporter = transfer.Export(request);
//   absl::StatusOr<std::unique_ptr<MapImporter>> importer = transfer.Import("copy");
//   ... (*importer)->Add(piece) ...;  absl::StatusOr<v1::Map> map = transfer.Finish(**importer);
//
// Errors: FailedPrecondition without a store (a server that keeps maps in memory only);
// Export: the map's lookup (MapService::FindMap) and the exporter's; Import:
// InvalidArgument naming map_id (validated as CreateMap does); Finish: the importer's.
//
// Thread safety: thread safe (no state but the MapService pointer).
#ifndef SERVER_CORE_TRANSFER_MAP_TRANSFER_H_
#define SERVER_CORE_TRANSFER_MAP_TRANSFER_H_

#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "server/core/maps/map_service.h"
#include "server/core/transfer/map_exporter.h"
#include "server/core/transfer/map_importer.h"
#include "skimap/v1/maps.pb.h"

namespace skimap::server {

class MapTransfer {
 public:
  // REQUIRES: `maps` outlives this.
  explicit MapTransfer(MapService* maps) : maps_(maps) {}

  absl::StatusOr<std::unique_ptr<MapExporter>> Export(const v1::ExportMapRequest& request) const;
  // `map_id`: "" keeps the file's id.
  absl::StatusOr<std::unique_ptr<MapImporter>> Import(const std::string& map_id) const;
  absl::StatusOr<v1::Map> Finish(MapImporter& importer) const;

 private:
  MapService* const maps_;
};

}  // namespace skimap::server

#endif  // SERVER_CORE_TRANSFER_MAP_TRANSFER_H_
