// PostgresMapStore: the MapStore on a PostgreSQL server (libpq), shared by the nodes of a
// fleet, and their LeaseStore (lease_store.h). Same contract as SqliteMapStore
// (map_store.h): AppendJournal returns after COMMIT with synchronous_commit on (the WAL
// record is flushed on the server), each call is one transaction, WriteSnapshot stores the
// chunks and the journal position they cover in one, and ReadSnapshot reads in one
// REPEATABLE READ transaction.
//
//   auto store = PostgresMapStore::Open("postgres://skimap@10.0.0.5/skimap",
//                                       {.node_id = "node-3f2a"});
//
// The SQL keeps to what PostgreSQL-compatible distributed engines also offer (docs/formats.md,
// "PostgreSQL store"): tables with primary and foreign keys (ON DELETE CASCADE), BIGINT /
// TEXT / BYTEA / BOOLEAN, INSERT ... ON CONFLICT, UPDATE ... RETURNING, SELECT ... FOR
// SHARE, row-value comparison, COLLATE "C", clock_timestamp(); no advisory locks, no
// extensions, no LISTEN/NOTIFY. Transactions that meet a serialization failure or a
// deadlock are retried from the start.
//
// With a node_id (a fleet node) every write to a map is fenced by the map's lease
// (lease_store.h): it takes the lease row FOR SHARE and checks holder and token in its own
// transaction, so a node that took the lease over (UPDATE of that row) is ordered after
// every write it lets through. Without one (a single server, tests, tools) writes are not
// fenced and the lease calls answer FailedPrecondition.
//
// Thread safety: thread safe (a pool of connections).
#ifndef SKIMAP_STORAGE_POSTGRES_MAP_STORE_H_
#define SKIMAP_STORAGE_POSTGRES_MAP_STORE_H_

#include <functional>
#include <map>
#include <memory>
#include <string>

#include "absl/base/thread_annotations.h"
#include "absl/time/time.h"
#include "base/mutex.h"
#include "storage/lease_store.h"
#include "storage/map_store.h"
#include "storage/postgres.h"

namespace skimap::storage {

class PostgresMapStore final : public MapStore, public LeaseStore {
 public:
  struct Options {
    int connections = 4;  // pool size: concurrent calls beyond it wait
    std::string node_id;  // "" = not a fleet node (writes unfenced)
    // Lease of the maps this node creates (CreateMap, BeginImport).
    absl::Duration lease_ttl = absl::Seconds(6);
  };
  // Connects to `dsn` (libpq connection string or postgres:// URI) and migrates the
  // schema. Unavailable (unreachable), FailedPrecondition (schema of newer software).
  static absl::StatusOr<std::unique_ptr<PostgresMapStore>> Open(const std::string& dsn,
                                                                const Options& options);

  // MapStore (map_store.h).
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

  // LeaseStore (lease_store.h; postgres_leases.cc).
  const std::string& node_id() const override { return options_.node_id; }
  absl::StatusOr<std::vector<std::string>> Heartbeat(const std::string& address,
                                                     absl::Duration ttl) override;
  absl::Status Leave() override;
  absl::StatusOr<std::vector<NodeInfo>> ListNodes(absl::Duration forget_after) override;
  absl::StatusOr<Lease> AcquireLease(const std::string& id, absl::Duration ttl) override;
  std::optional<Held> HeldLease(const std::string& id) override;
  absl::StatusOr<std::vector<Lease>> ListLeases() override;

 private:
  using Clock = std::chrono::steady_clock;
  PostgresMapStore(std::unique_ptr<PgPool> pool, const Options& options)
      : options_(options), pool_(std::move(pool)) {}
  // Runs fn in one transaction on a pooled connection, again from the start (up to 5
  // times) when it meets a serialization failure or a deadlock; commits if fn succeeds.
  template <class T>
  absl::StatusOr<T> InTransaction(std::string_view mode,
                                  const std::function<absl::StatusOr<T>(PgConnection&)>& fn);
  absl::Status InTransaction(const std::function<absl::Status(PgConnection&)>& fn);
  // Fleet nodes: FailedPrecondition unless the lease of `id` names this node with the
  // token it holds (the row is locked FOR SHARE until the transaction ends). OK otherwise.
  absl::Status CheckFence(PgConnection& c, const std::string& id);
  absl::StatusOr<StoredMap> GetMapOn(PgConnection& c, const std::string& id);
  absl::Status Insert(const std::string& id, const std::string& options, uint64_t last_position,
                      bool importing);
  // Pages of the latest snapshot in key order from `after`; returns the covered position.
  absl::StatusOr<uint64_t> ReadChunks(const std::string& id, std::optional<ChunkKey> after,
                                      size_t limit,
                                      const std::function<absl::Status(const Chunk&)>& fn);
  void SetFence(const std::string& id, int64_t token, Clock::time_point valid_until);
  void DropFence(const std::string& id);

  const Options options_;
  std::unique_ptr<PgPool> pool_;
  Mutex fence_mu_;
  std::map<std::string, Held> fences_ ABSL_GUARDED_BY(fence_mu_);  // leases this node holds
};

template <class T>
absl::StatusOr<T> PostgresMapStore::InTransaction(
    std::string_view mode, const std::function<absl::StatusOr<T>(PgConnection&)>& fn) {
  constexpr int kAttempts = 5;
  PgPool::Lease c = pool_->Take();
  absl::StatusOr<T> result = absl::UnknownError("not run");
  for (int attempt = 0; attempt < kAttempts; ++attempt) {
    PgTransaction tx(*c, mode);
    if (!tx.status().ok()) return tx.status();
    result = fn(*c);
    if (result.ok()) {
      absl::Status committed = tx.Commit();
      if (!committed.ok()) result = committed;
    }
    if (!IsRetryable(result.status())) return result;
  }
  return result;
}

}  // namespace skimap::storage

#endif  // SKIMAP_STORAGE_POSTGRES_MAP_STORE_H_
