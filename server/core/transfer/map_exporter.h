// MapExporter: the bytes of one map's export file (map_export.h), made piece by piece from
// the store: it snapshots the map, then reads a page of chunks or a batch of journal
// records at a time, so that no step holds the whole map in memory.
//
//   absl::StatusOr<std::unique_ptr<MapExporter>> e =
//       MapExporter::Start(map, store, {.with_journal = true});
//   while (auto piece = (*e)->Next(); piece.ok() && piece->has_value()) send(**piece);
//
// Consistency: Start writes a snapshot and holds the map's later snapshots and journal
// pruning (LiveMap::SnapshotAndHold) until the exporter is destroyed, so the pages read one
// after the other form that snapshot, and the journal is read from the first record kept
// up to the last one appended when the export started (frames arriving during the export
// are not in it). Should the store change anyway (the map evicted and reloaded by another
// instance), Next answers Aborted rather than mixing two snapshots.
//
// Thread safety: a single-threaded value (one call at a time).
#ifndef SERVER_CORE_TRANSFER_MAP_EXPORTER_H_
#define SERVER_CORE_TRANSFER_MAP_EXPORTER_H_

#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "absl/status/statusor.h"
#include "server/core/maps/live_map.h"
#include "server/core/transfer/map_export.h"
#include "storage/map_store.h"

namespace skimap::server {

class MapExporter {
 public:
  struct Options {
    bool with_journal = false;             // also the journal records the store keeps
    size_t piece_bytes = size_t{1} << 20;  // largest piece Next returns (>= 1)
  };

  // Snapshots `map` (REQUIRES: it lives in `store`, which outlives the exporter) and reads
  // its header. Errors: the snapshot's, the store's.
  static absl::StatusOr<std::unique_ptr<MapExporter>> Start(std::shared_ptr<LiveMap> map,
                                                            storage::MapStore* store,
                                                            const Options& options);

  // The next piece of the file (1..piece_bytes bytes), or nullopt after the last one.
  // Errors: NotFound (the map was deleted meanwhile), Aborted (see above), the store's.
  absl::StatusOr<std::optional<std::string>> Next();

 private:
  enum class Stage { kChunks, kJournal, kEnd, kDone };
  MapExporter(std::shared_ptr<LiveMap> map, LiveMap::SnapshotHold hold, storage::MapStore* store,
              const Options& options)
      : map_(std::move(map)), hold_(std::move(hold)), store_(store), options_(options) {}
  // Appends the next page of chunks, batch of journal records or the end record.
  absl::Status Fill();
  absl::Status FillChunks();
  absl::Status FillJournal();

  std::shared_ptr<LiveMap> map_;
  LiveMap::SnapshotHold hold_;  // after map_: released first
  storage::MapStore* const store_;
  const Options options_;
  std::optional<ExportWriter> writer_;
  Stage stage_ = Stage::kChunks;
  uint64_t snapshot_position_ = 0;
  std::optional<storage::ChunkKey> after_;  // last chunk read
  uint64_t journal_next_ = 0;               // next journal position to read
  uint64_t journal_end_ = 0;                // last journal position exported
  std::string pending_;                     // bytes made, not yet returned, from offset_
  size_t offset_ = 0;
};

}  // namespace skimap::server

#endif  // SERVER_CORE_TRANSFER_MAP_EXPORTER_H_
