// MapStore: the only door between the map server and disk for maps: the map list with each
// map's options, the frame journal, and the snapshot chunks of every volume. Backends
// implement it (SqliteMapStore: the embedded default); this header names no database type,
// so a networked backend for several server nodes can follow without touching server/.
//
//   std::unique_ptr<MapStore> store = *SqliteMapStore::Open("DATA_DIR/maps.sqlite");
//   store->CreateMap("kitchen", options_bytes);
//   uint64_t last = *store->AppendJournal("kitchen", {{JournalRecord::kFrame, frame_bytes}});
//   // durable: the ack may go out now
//
// Imports (a map brought from an export file) create the map with BeginImport, write its
// chunks and journal, and end with FinishImport; until then the map is marked importing,
// and a server that finds such a map at start deletes it (the import did not finish).
//
// Payloads are opaque bytes to the store (the server encodes frames, pose updates, options
// and chunks; docs/formats.md). Positions are per map, 1, 2, 3, ... in append order.
//
// Contract every backend meets (tests/storage/map_store_conformance_test.cc):
// - AppendJournal returns only after its records are durable (they survive a crash or
//   power loss of this process and machine); several records append all or nothing.
// - WriteSnapshot stores the changed chunks, drops the removed ones and records the journal
//   position the snapshot covers in one atomic step: a reader sees the previous snapshot
//   whole or the new one whole, never a mix.
// - DeleteMap removes the map's journal and chunks with it.
// - ReadSnapshotPage walks the chunks in key order; pages read by successive calls belong
//   to one snapshot only if no WriteSnapshot of that map ran between them (callers that
//   page keep the map's snapshots from running meanwhile).
// - Errors: NotFound (unknown map), AlreadyExists (CreateMap), InvalidArgument (bad
//   arguments), ResourceExhausted (disk full), Unavailable (I/O, read-only), DataLoss
//   (corrupt store); a failed call changes nothing.
//
// Thread safety: implementations are thread safe.
#ifndef SKIMAP_STORAGE_MAP_STORE_H_
#define SKIMAP_STORAGE_MAP_STORE_H_

#include <compare>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"

namespace skimap::storage {

struct StoredMap {
  std::string id;
  std::string options;             // the server's encoding of the map's options
  uint64_t last_position = 0;      // last journal position appended (0: none)
  uint64_t snapshot_position = 0;  // journal position the last snapshot covers (0: none)
  int64_t snapshot_unix_ms = 0;    // when it was written (0: none)
  bool importing = false;          // between BeginImport and FinishImport
};

struct JournalRecord {
  enum Kind : int { kFrame = 1, kPoseUpdate = 2 };
  Kind kind = kFrame;
  std::string payload;
  uint64_t position = 0;  // set by the store (ignored by AppendJournal)
};

// One chunk of one volume: a block of voxels keyed by volume name and chunk coordinates.
struct ChunkKey {
  std::string volume;  // "rgb", "free", ...
  int64_t x = 0, y = 0, z = 0;
  bool operator==(const ChunkKey&) const = default;
  auto operator<=>(const ChunkKey&) const = default;  // key order: volume (bytes), x, y, z
};
struct Chunk {
  ChunkKey key;
  std::string bytes;  // encoded and checksummed by the server (codec id, version, CRC)
};

class MapStore {
 public:
  virtual ~MapStore() = default;

  virtual absl::Status CreateMap(const std::string& id, const std::string& options) = 0;
  virtual absl::Status DeleteMap(const std::string& id) = 0;
  // Starts an import: creates map `id` like CreateMap, marked importing until FinishImport,
  // with its journal continuing after `journal_base`: the first AppendJournal returns
  // journal_base + 1, the positions up to it read as pruned, and a snapshot may cover up to
  // it. Errors as CreateMap.
  virtual absl::Status BeginImport(const std::string& id, const std::string& options,
                                   uint64_t journal_base) = 0;
  // Clears the importing mark of map `id`. NotFound (unknown map).
  virtual absl::Status FinishImport(const std::string& id) = 0;
  // Every stored map, ordered by id.
  virtual absl::StatusOr<std::vector<StoredMap>> ListMaps() = 0;
  virtual absl::StatusOr<StoredMap> GetMap(const std::string& id) = 0;

  // Appends `records` (at least one) durably; returns the position of the last one.
  virtual absl::StatusOr<uint64_t> AppendJournal(const std::string& id,
                                                 const std::vector<JournalRecord>& records) = 0;
  // Calls fn for the first `limit` records with position > after, in order; stops at fn's
  // first error. fn must not call this store (a backend may hold its lock while it reads):
  // callers that must, read in batches of `limit`.
  virtual absl::Status ReadJournal(const std::string& id, uint64_t after, size_t limit,
                                   const std::function<absl::Status(const JournalRecord&)>& fn) = 0;
  // The record at `position`; NotFound if the map has none there (pruned or never written).
  virtual absl::StatusOr<JournalRecord> ReadJournalRecord(const std::string& id,
                                                          uint64_t position) = 0;
  // Drops the records with position <= upto (they are covered by a snapshot).
  virtual absl::Status PruneJournal(const std::string& id, uint64_t upto) = 0;

  // Atomically: stores `changed` (replacing chunks of the same key), drops `removed`, and
  // records that the snapshot covers the journal up to `covers_position`.
  // InvalidArgument if covers_position is behind the current snapshot's or beyond the
  // journal's last position.
  virtual absl::Status WriteSnapshot(const std::string& id, uint64_t covers_position,
                                     const std::vector<Chunk>& changed,
                                     const std::vector<ChunkKey>& removed) = 0;
  // Calls fn for every chunk of the latest snapshot (any order); returns the position it
  // covers.
  virtual absl::StatusOr<uint64_t> ReadSnapshot(
      const std::string& id, const std::function<absl::Status(const Chunk&)>& fn) = 0;
  // Calls fn for the first `limit` chunks of the latest snapshot in key order whose key is
  // greater than `after` (every chunk when absent), stopping at fn's first error; returns
  // the position the snapshot covers. fn must not call this store.
  virtual absl::StatusOr<uint64_t> ReadSnapshotPage(
      const std::string& id, const std::optional<ChunkKey>& after, size_t limit,
      const std::function<absl::Status(const Chunk&)>& fn) = 0;
};

}  // namespace skimap::storage

#endif  // SKIMAP_STORAGE_MAP_STORE_H_
