// SqliteMapStore: the embedded MapStore backend, one SQLite file (DATA_DIR/maps.sqlite) in
// WAL mode with synchronous=FULL, so that AppendJournal's commit is on disk (fsync) before
// it returns. Schema and migrations: map_store_schema.cc, docs/formats.md.
//
// Thread safety: thread safe (one connection behind a mutex).
#ifndef SKIMAP_STORAGE_SQLITE_MAP_STORE_H_
#define SKIMAP_STORAGE_SQLITE_MAP_STORE_H_

#include <memory>
#include <mutex>
#include <string>

#include "storage/map_store.h"
#include "storage/sqlite.h"

namespace skimap::storage {

class SqliteMapStore final : public MapStore {
 public:
  // Opens or creates the store at `path` and migrates its schema. FailedPrecondition for a
  // file written by newer software; Unavailable / DataLoss for unreadable or corrupt files.
  static absl::StatusOr<std::unique_ptr<SqliteMapStore>> Open(const std::string& path);

  absl::Status CreateMap(const std::string& id, const std::string& options) override;
  absl::Status DeleteMap(const std::string& id) override;
  absl::Status BeginImport(const std::string& id, const std::string& options,
                           uint64_t journal_base) override;
  absl::Status FinishImport(const std::string& id) override;
  absl::StatusOr<std::vector<StoredMap>> ListMaps() override;
  absl::StatusOr<StoredMap> GetMap(const std::string& id) override;
  absl::StatusOr<uint64_t> AppendJournal(const std::string& id,
                                         const std::vector<JournalRecord>& records) override;
  absl::Status ReadJournal(const std::string& id, uint64_t after, size_t limit,
                           const std::function<absl::Status(const JournalRecord&)>& fn) override;
  absl::StatusOr<JournalRecord> ReadJournalRecord(const std::string& id,
                                                  uint64_t position) override;
  absl::Status PruneJournal(const std::string& id, uint64_t upto) override;
  absl::Status WriteSnapshot(const std::string& id, uint64_t covers_position,
                             const std::vector<Chunk>& changed,
                             const std::vector<ChunkKey>& removed) override;
  absl::StatusOr<uint64_t> ReadSnapshot(
      const std::string& id, const std::function<absl::Status(const Chunk&)>& fn) override;
  absl::StatusOr<uint64_t> ReadSnapshotPage(
      const std::string& id, const std::optional<ChunkKey>& after, size_t limit,
      const std::function<absl::Status(const Chunk&)>& fn) override;

 private:
  explicit SqliteMapStore(std::unique_ptr<Database> db) : db_(std::move(db)) {}
  absl::StatusOr<StoredMap> GetMapLocked(const std::string& id);
  // CreateMap and BeginImport: a new row for map `id`.
  absl::Status Insert(const std::string& id, const std::string& options, uint64_t last_position,
                      bool importing);
  // The journal record in the current row of `st` (position, kind, payload).
  static absl::StatusOr<JournalRecord> RecordAt(const std::string& id, Statement& st);

  std::mutex mu_;
  std::unique_ptr<Database> db_;  // guarded by mu_
};

}  // namespace skimap::storage

#endif  // SKIMAP_STORAGE_SQLITE_MAP_STORE_H_
