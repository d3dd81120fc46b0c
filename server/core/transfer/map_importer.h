// MapImporter: one import under way. It parses the pieces of an export file as they come
// (map_export.h) and writes the map into the store under its new id as it goes (chunks and
// journal in batches of a few MiB, the map marked importing), so that nothing holds the
// whole file. Finish then loads the map the way a restart would (LiveMap::Load: every
// chunk decoded and checked, the journal after the snapshot replayed), clears the mark and
// publishes it in the registry.
//
//   MapImporter importer(&registry, store, "copy");   // "" keeps the file's id
//   importer.Add(piece) ...                            // every piece, in order
//   absl::StatusOr<std::shared_ptr<LiveMap>> map = importer.Finish();
//
// Positions: the journal keeps the positions it had (BeginImport continues it after the
// file's journal base), so the frame index's positions still name the right records.
// Without a journal in the file, the base is the snapshot's position: the frames before it
// count as pruned (UpdatePoses on them answers FailedPrecondition) and new frames append
// after it.
//
// Failure: the first error ends the import (later calls return it) and deletes whatever
// was written, as does destroying an importer before Finish succeeded: nothing half
// imported remains in the store or the registry. If the process dies meanwhile, the map
// stays marked importing and the next start deletes it (MapService::Recover).
//
// Errors: DataLoss (corrupt or truncated file, naming record and offset, or a chunk that
// does not decode, naming it), FailedPrecondition (a newer file format or chunk version),
// AlreadyExists (the id is taken), InvalidArgument (a bad id or options), the store's.
//
// Thread safety: a single-threaded value (one call at a time).
#ifndef SERVER_CORE_TRANSFER_MAP_IMPORTER_H_
#define SERVER_CORE_TRANSFER_MAP_IMPORTER_H_

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "server/core/maps/map_config.h"
#include "server/core/maps/map_registry.h"
#include "server/core/transfer/map_export.h"
#include "storage/map_store.h"

namespace skimap::server {

class MapImporter {
 public:
  // REQUIRES: registry and store outlive the importer; `map_id` is "" (the file's id) or
  // passed ValidateMapId.
  MapImporter(MapRegistry* registry, storage::MapStore* store, std::string map_id)
      : registry_(registry), store_(store), requested_id_(std::move(map_id)) {}
  ~MapImporter() { Abort(); }
  MapImporter(const MapImporter&) = delete;
  MapImporter& operator=(const MapImporter&) = delete;

  // Parses and writes the next bytes of the file.
  absl::Status Add(std::string_view bytes);
  // After the last piece: checks the end of the file, loads and publishes the map.
  absl::StatusOr<std::shared_ptr<LiveMap>> Finish();

 private:
  absl::Status Apply(ExportRecord record);
  absl::Status Begin(const ExportedMap& map);
  absl::Status FlushChunks();
  absl::Status FlushJournal();
  // Returns `s` after deleting what the import wrote; `s` stays the importer's answer.
  absl::Status Fail(absl::Status s);
  void Abort();
  // The store's error, naming the import.
  absl::Status StoreError(const absl::Status& s) const;

  MapRegistry* const registry_;
  storage::MapStore* const store_;
  const std::string requested_id_;
  ExportReader reader_;
  std::string id_;  // the map's id, once the map record was read
  MapConfig config_;
  bool reserved_ = false;  // id_ reserved in the registry
  bool created_ = false;   // map id_ created in the store
  bool done_ = false;      // published
  absl::Status error_;
  uint64_t snapshot_position_ = 0;
  std::vector<storage::Chunk> chunks_;  // not yet written
  std::vector<storage::JournalRecord> journal_;
  size_t pending_bytes_ = 0;
};

}  // namespace skimap::server

#endif  // SERVER_CORE_TRANSFER_MAP_IMPORTER_H_
