#include "storage/sqlite_map_store.h"

#include <algorithm>
#include <chrono>
#include <climits>

#include "absl/strings/str_cat.h"
#include "storage/migrations.h"
#include "storage/status_macros.h"

namespace skimap::storage {
namespace {

// Version 1 of maps.sqlite. Journal payloads and chunks are large blobs: ordinary rowid
// tables with a unique key, not WITHOUT ROWID (SQLite's advice for rows over ~1/20 page).
constexpr char kMapStoreV1[] = R"sql(
CREATE TABLE maps (
  id TEXT PRIMARY KEY,
  options BLOB NOT NULL,
  last_position INTEGER NOT NULL DEFAULT 0,
  snapshot_position INTEGER NOT NULL DEFAULT 0,
  snapshot_unix_ms INTEGER NOT NULL DEFAULT 0
);
CREATE TABLE journal (
  map TEXT NOT NULL REFERENCES maps(id) ON DELETE CASCADE,
  position INTEGER NOT NULL,
  kind INTEGER NOT NULL,
  payload BLOB NOT NULL,
  UNIQUE (map, position)
);
CREATE TABLE chunks (
  map TEXT NOT NULL REFERENCES maps(id) ON DELETE CASCADE,
  volume TEXT NOT NULL,
  cx INTEGER NOT NULL,
  cy INTEGER NOT NULL,
  cz INTEGER NOT NULL,
  bytes BLOB NOT NULL,
  UNIQUE (map, volume, cx, cy, cz)
);
)sql";

// Version 2: imports (BeginImport .. FinishImport) mark their map until they finish.
constexpr char kMapStoreV2[] = R"sql(
ALTER TABLE maps ADD COLUMN importing INTEGER NOT NULL DEFAULT 0;
)sql";

constexpr Migration kMapStoreMigrations[] = {
    {1, "map store: maps, journal, chunks", kMapStoreV1},
    {2, "map store: importing mark", kMapStoreV2},
};

constexpr char kMapColumns[] =
    "id, options, last_position, snapshot_position, snapshot_unix_ms, importing";

// The map in the current row of a statement selecting kMapColumns.
StoredMap MapAt(const Statement& st) {
  return StoredMap{st.ColumnText(0),          st.ColumnBlob(1), uint64_t(st.ColumnInt(2)),
                   uint64_t(st.ColumnInt(3)), st.ColumnInt(4),  st.ColumnInt(5) != 0};
}

absl::Status NoMap(const std::string& id) {
  return absl::NotFoundError(absl::StrCat("map store: no map ", id));
}

int64_t NowUnixMs() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

}  // namespace

absl::StatusOr<std::unique_ptr<SqliteMapStore>> SqliteMapStore::Open(const std::string& path) {
  SK_ASSIGN_OR_RETURN(db, Database::Open(path));
  // A new file gets 64 KiB pages (an existing one keeps its own: SQLite sets the page size
  // only before the first table): journal payloads are ~1 MB blobs, and the WAL writes each
  // page as its own frame, two system calls per page; 16 times fewer pages per frame.
  // WAL: readers never block the writer; FULL: every commit is fsynced before it returns.
  SK_RETURN_IF_ERROR(
      db->Exec("PRAGMA page_size=65536; PRAGMA journal_mode=WAL; PRAGMA synchronous=FULL;"));
  SK_RETURN_IF_ERROR(Migrate(*db, kMapStoreMigrations));
  return std::unique_ptr<SqliteMapStore>(new SqliteMapStore(std::move(db)));
}

absl::Status SqliteMapStore::CreateMap(const std::string& id, const std::string& options) {
  return Insert(id, options, 0, false);
}

absl::Status SqliteMapStore::BeginImport(const std::string& id, const std::string& options,
                                         uint64_t journal_base) {
  return Insert(id, options, journal_base, true);
}

absl::Status SqliteMapStore::Insert(const std::string& id, const std::string& options,
                                    uint64_t last_position, bool importing) {
  if (id.empty()) return absl::InvalidArgumentError("map store: empty map id");
  if (last_position > uint64_t(INT64_MAX)) {
    return absl::InvalidArgumentError("map store: journal base beyond 2^63");
  }
  std::lock_guard<std::mutex> lock(mu_);
  Transaction tx(*db_);
  SK_RETURN_IF_ERROR(tx.status());
  SK_ASSIGN_OR_RETURN(exists, db_->Prepare("SELECT 1 FROM maps WHERE id = ?"));
  SK_RETURN_IF_ERROR(exists.BindText(1, id));
  SK_ASSIGN_OR_RETURN(found, exists.Step());
  if (found) return absl::AlreadyExistsError(absl::StrCat("map store: map ", id, " exists"));
  SK_ASSIGN_OR_RETURN(insert, db_->Prepare("INSERT INTO maps (id, options, last_position, "
                                           "importing) VALUES (?, ?, ?, ?)"));
  SK_RETURN_IF_ERROR(insert.BindText(1, id));
  SK_RETURN_IF_ERROR(insert.BindBlob(2, options));
  SK_RETURN_IF_ERROR(insert.BindInt(3, int64_t(last_position)));
  SK_RETURN_IF_ERROR(insert.BindInt(4, importing ? 1 : 0));
  SK_RETURN_IF_ERROR(insert.Run());
  return tx.Commit();
}

absl::Status SqliteMapStore::FinishImport(const std::string& id) {
  std::lock_guard<std::mutex> lock(mu_);
  Transaction tx(*db_);
  SK_RETURN_IF_ERROR(tx.status());
  SK_RETURN_IF_ERROR(GetMapLocked(id).status());
  SK_ASSIGN_OR_RETURN(mark, db_->Prepare("UPDATE maps SET importing = 0 WHERE id = ?"));
  SK_RETURN_IF_ERROR(mark.BindText(1, id));
  SK_RETURN_IF_ERROR(mark.Run());
  return tx.Commit();
}

absl::Status SqliteMapStore::DeleteMap(const std::string& id) {
  std::lock_guard<std::mutex> lock(mu_);
  Transaction tx(*db_);
  SK_RETURN_IF_ERROR(tx.status());
  SK_RETURN_IF_ERROR(GetMapLocked(id).status());
  // The foreign keys cascade to the journal and the chunks.
  SK_ASSIGN_OR_RETURN(del, db_->Prepare("DELETE FROM maps WHERE id = ?"));
  SK_RETURN_IF_ERROR(del.BindText(1, id));
  SK_RETURN_IF_ERROR(del.Run());
  return tx.Commit();
}

absl::StatusOr<StoredMap> SqliteMapStore::GetMapLocked(const std::string& id) {
  SK_ASSIGN_OR_RETURN(
      st, db_->Prepare(absl::StrCat("SELECT ", kMapColumns, " FROM maps WHERE id = ?")));
  SK_RETURN_IF_ERROR(st.BindText(1, id));
  SK_ASSIGN_OR_RETURN(row, st.Step());
  if (!row) return NoMap(id);
  return MapAt(st);
}

absl::StatusOr<StoredMap> SqliteMapStore::GetMap(const std::string& id) {
  std::lock_guard<std::mutex> lock(mu_);
  return GetMapLocked(id);
}

absl::StatusOr<std::vector<StoredMap>> SqliteMapStore::ListMaps() {
  std::lock_guard<std::mutex> lock(mu_);
  SK_ASSIGN_OR_RETURN(st,
                      db_->Prepare(absl::StrCat("SELECT ", kMapColumns, " FROM maps ORDER BY id")));
  std::vector<StoredMap> out;
  while (true) {
    SK_ASSIGN_OR_RETURN(row, st.Step());
    if (!row) break;
    out.push_back(MapAt(st));
  }
  return out;
}

absl::StatusOr<uint64_t> SqliteMapStore::AppendJournal(const std::string& id,
                                                       const std::vector<JournalRecord>& records) {
  if (records.empty()) return absl::InvalidArgumentError("map store: no journal record");
  std::lock_guard<std::mutex> lock(mu_);
  Transaction tx(*db_);
  SK_RETURN_IF_ERROR(tx.status());
  SK_ASSIGN_OR_RETURN(map, GetMapLocked(id));
  SK_ASSIGN_OR_RETURN(
      insert,
      db_->Prepare("INSERT INTO journal (map, position, kind, payload) VALUES (?, ?, ?, ?)"));
  uint64_t position = map.last_position;
  for (const JournalRecord& r : records) {
    if (r.kind != JournalRecord::kFrame && r.kind != JournalRecord::kPoseUpdate) {
      return absl::InvalidArgumentError("map store: unknown journal record kind");
    }
    insert.Reset();
    SK_RETURN_IF_ERROR(insert.BindText(1, id));
    SK_RETURN_IF_ERROR(insert.BindInt(2, int64_t(++position)));
    SK_RETURN_IF_ERROR(insert.BindInt(3, r.kind));
    // `records` outlives `insert`: no copy of the payload.
    SK_RETURN_IF_ERROR(insert.BindBlobInPlace(4, r.payload));
    SK_RETURN_IF_ERROR(insert.Run());
  }
  SK_ASSIGN_OR_RETURN(update, db_->Prepare("UPDATE maps SET last_position = ? WHERE id = ?"));
  SK_RETURN_IF_ERROR(update.BindInt(1, int64_t(position)));
  SK_RETURN_IF_ERROR(update.BindText(2, id));
  SK_RETURN_IF_ERROR(update.Run());
  SK_RETURN_IF_ERROR(tx.Commit());  // synchronous=FULL: durable here
  return position;
}

absl::StatusOr<JournalRecord> SqliteMapStore::RecordAt(const std::string& id, Statement& st) {
  const int64_t kind = st.ColumnInt(1);
  if (kind != JournalRecord::kFrame && kind != JournalRecord::kPoseUpdate) {
    return absl::DataLossError(
        absl::StrCat("map store: map ", id, ": journal record of unknown kind ", kind));
  }
  return JournalRecord{JournalRecord::Kind(kind), st.ColumnBlob(2), uint64_t(st.ColumnInt(0))};
}

absl::Status SqliteMapStore::ReadJournal(
    const std::string& id, uint64_t after, size_t limit,
    const std::function<absl::Status(const JournalRecord&)>& fn) {
  std::lock_guard<std::mutex> lock(mu_);
  SK_RETURN_IF_ERROR(GetMapLocked(id).status());
  SK_ASSIGN_OR_RETURN(st, db_->Prepare("SELECT position, kind, payload FROM journal "
                                       "WHERE map = ? AND position > ? ORDER BY position "
                                       "LIMIT ?"));
  SK_RETURN_IF_ERROR(st.BindText(1, id));
  SK_RETURN_IF_ERROR(st.BindInt(2, int64_t(after)));
  SK_RETURN_IF_ERROR(st.BindInt(3, int64_t(std::min<size_t>(limit, INT64_MAX))));
  while (true) {
    SK_ASSIGN_OR_RETURN(row, st.Step());
    if (!row) return absl::OkStatus();
    SK_ASSIGN_OR_RETURN(record, RecordAt(id, st));
    SK_RETURN_IF_ERROR(fn(record));
  }
}

absl::StatusOr<JournalRecord> SqliteMapStore::ReadJournalRecord(const std::string& id,
                                                                uint64_t position) {
  std::lock_guard<std::mutex> lock(mu_);
  SK_RETURN_IF_ERROR(GetMapLocked(id).status());
  SK_ASSIGN_OR_RETURN(st, db_->Prepare("SELECT position, kind, payload FROM journal "
                                       "WHERE map = ? AND position = ?"));
  SK_RETURN_IF_ERROR(st.BindText(1, id));
  SK_RETURN_IF_ERROR(st.BindInt(2, int64_t(position)));
  SK_ASSIGN_OR_RETURN(row, st.Step());
  if (!row) {
    return absl::NotFoundError(
        absl::StrCat("map store: map ", id, ": no journal record at position ", position));
  }
  return RecordAt(id, st);
}

absl::Status SqliteMapStore::PruneJournal(const std::string& id, uint64_t upto) {
  std::lock_guard<std::mutex> lock(mu_);
  SK_RETURN_IF_ERROR(GetMapLocked(id).status());
  SK_ASSIGN_OR_RETURN(del, db_->Prepare("DELETE FROM journal WHERE map = ? AND position <= ?"));
  SK_RETURN_IF_ERROR(del.BindText(1, id));
  SK_RETURN_IF_ERROR(del.BindInt(2, int64_t(upto)));
  return del.Run();
}

absl::Status SqliteMapStore::WriteSnapshot(const std::string& id, uint64_t covers_position,
                                           const std::vector<Chunk>& changed,
                                           const std::vector<ChunkKey>& removed) {
  std::lock_guard<std::mutex> lock(mu_);
  Transaction tx(*db_);
  SK_RETURN_IF_ERROR(tx.status());
  SK_ASSIGN_OR_RETURN(map, GetMapLocked(id));
  if (covers_position < map.snapshot_position || covers_position > map.last_position) {
    return absl::InvalidArgumentError(
        absl::StrCat("map store: map ", id, ": a snapshot covering position ", covers_position,
                     " is outside [", map.snapshot_position, ", ", map.last_position, "]"));
  }
  SK_ASSIGN_OR_RETURN(put, db_->Prepare("INSERT OR REPLACE INTO chunks (map, volume, cx, cy, cz, "
                                        "bytes) VALUES (?, ?, ?, ?, ?, ?)"));
  for (const Chunk& c : changed) {
    put.Reset();
    SK_RETURN_IF_ERROR(put.BindText(1, id));
    SK_RETURN_IF_ERROR(put.BindText(2, c.key.volume));
    SK_RETURN_IF_ERROR(put.BindInt(3, c.key.x));
    SK_RETURN_IF_ERROR(put.BindInt(4, c.key.y));
    SK_RETURN_IF_ERROR(put.BindInt(5, c.key.z));
    SK_RETURN_IF_ERROR(put.BindBlob(6, c.bytes));
    SK_RETURN_IF_ERROR(put.Run());
  }
  SK_ASSIGN_OR_RETURN(del, db_->Prepare("DELETE FROM chunks WHERE map = ? AND volume = ? AND "
                                        "cx = ? AND cy = ? AND cz = ?"));
  for (const ChunkKey& k : removed) {
    del.Reset();
    SK_RETURN_IF_ERROR(del.BindText(1, id));
    SK_RETURN_IF_ERROR(del.BindText(2, k.volume));
    SK_RETURN_IF_ERROR(del.BindInt(3, k.x));
    SK_RETURN_IF_ERROR(del.BindInt(4, k.y));
    SK_RETURN_IF_ERROR(del.BindInt(5, k.z));
    SK_RETURN_IF_ERROR(del.Run());
  }
  SK_ASSIGN_OR_RETURN(mark, db_->Prepare("UPDATE maps SET snapshot_position = ?, "
                                         "snapshot_unix_ms = ? WHERE id = ?"));
  SK_RETURN_IF_ERROR(mark.BindInt(1, int64_t(covers_position)));
  SK_RETURN_IF_ERROR(mark.BindInt(2, NowUnixMs()));
  SK_RETURN_IF_ERROR(mark.BindText(3, id));
  SK_RETURN_IF_ERROR(mark.Run());
  return tx.Commit();
}

absl::StatusOr<uint64_t> SqliteMapStore::ReadSnapshot(
    const std::string& id, const std::function<absl::Status(const Chunk&)>& fn) {
  std::lock_guard<std::mutex> lock(mu_);
  // One read transaction: the chunks and the position come from the same snapshot.
  SK_RETURN_IF_ERROR(db_->Exec("BEGIN"));
  auto read = [&]() -> absl::StatusOr<uint64_t> {
    SK_ASSIGN_OR_RETURN(map, GetMapLocked(id));
    SK_ASSIGN_OR_RETURN(st, db_->Prepare("SELECT volume, cx, cy, cz, bytes FROM chunks "
                                         "WHERE map = ?"));
    SK_RETURN_IF_ERROR(st.BindText(1, id));
    while (true) {
      SK_ASSIGN_OR_RETURN(row, st.Step());
      if (!row) return map.snapshot_position;
      Chunk c{{st.ColumnText(0), st.ColumnInt(1), st.ColumnInt(2), st.ColumnInt(3)},
              st.ColumnBlob(4)};
      SK_RETURN_IF_ERROR(fn(c));
    }
  };
  absl::StatusOr<uint64_t> result = read();
  absl::Status end = db_->Exec("COMMIT");
  if (result.ok() && !end.ok()) return end;
  return result;
}

absl::StatusOr<uint64_t> SqliteMapStore::ReadSnapshotPage(
    const std::string& id, const std::optional<ChunkKey>& after, size_t limit,
    const std::function<absl::Status(const Chunk&)>& fn) {
  std::lock_guard<std::mutex> lock(mu_);
  SK_RETURN_IF_ERROR(db_->Exec("BEGIN"));
  auto read = [&]() -> absl::StatusOr<uint64_t> {
    SK_ASSIGN_OR_RETURN(map, GetMapLocked(id));
    // Row values walk the UNIQUE (map, volume, cx, cy, cz) index from `after` on.
    SK_ASSIGN_OR_RETURN(st,
                        db_->Prepare(absl::StrCat(
                            "SELECT volume, cx, cy, cz, bytes FROM chunks WHERE map = ?1",
                            after.has_value() ? " AND (volume, cx, cy, cz) > (?2, ?3, ?4, ?5)" : "",
                            " ORDER BY volume, cx, cy, cz LIMIT ?6")));
    SK_RETURN_IF_ERROR(st.BindText(1, id));
    if (after.has_value()) {
      SK_RETURN_IF_ERROR(st.BindText(2, after->volume));
      SK_RETURN_IF_ERROR(st.BindInt(3, after->x));
      SK_RETURN_IF_ERROR(st.BindInt(4, after->y));
      SK_RETURN_IF_ERROR(st.BindInt(5, after->z));
    }
    SK_RETURN_IF_ERROR(st.BindInt(6, int64_t(std::min<size_t>(limit, INT64_MAX))));
    while (true) {
      SK_ASSIGN_OR_RETURN(row, st.Step());
      if (!row) return map.snapshot_position;
      Chunk c{{st.ColumnText(0), st.ColumnInt(1), st.ColumnInt(2), st.ColumnInt(3)},
              st.ColumnBlob(4)};
      SK_RETURN_IF_ERROR(fn(c));
    }
  };
  absl::StatusOr<uint64_t> result = read();
  absl::Status end = db_->Exec("COMMIT");
  if (result.ok() && !end.ok()) return end;
  return result;
}

}  // namespace skimap::storage
