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
// On a replicated cluster (a DSN listing the hosts; postgres.h) a call that loses its
// connection reconnects, to whichever host is primary now, with backoff for up to
// failover_timeout (its pooled connection given back while it waits), and runs its
// transaction again. A COMMIT whose answer was lost has an unknown outcome; the rerun
// settles it after taking the lock the lost transaction held, so that transaction has
// ended on this server and what it reads is final:
// - AppendJournal locks the map's row (FOR UPDATE), then compares the records stored at
//   the positions the lost attempt numbered (the row lock orders appends; positions are
//   never reused) with its own, byte for byte: equal, it committed and its positions are
//   the answer; not, it did not and the append runs again.
// - CreateMap / BeginImport: a unique conflict with the map this call's lost attempt made
//   (same options, this node's first lease) is success; DeleteMap: a map gone after its
//   lost attempt is success (FOR UPDATE waits for that attempt).
// - The other writes are idempotent and run again.
// An append still unsettled when the budget runs out is kept per map; the map's next
// append settles it first, and a re-sent record equal to one that did commit is answered
// its position, not written twice.
//
// With require_synchronous_standby an append is acknowledged only once a synchronous
// standby has it: it is written only while the primary's synchronous_standby_names is set
// (read in the same transaction), and the setting is read again after its COMMIT, since
// clearing it (pg_auto_failover does when a standby fails) releases waiting COMMITs
// without a standby. Found cleared, the append waits, within failover_timeout, and settles
// as above: a committed record is then made durable by a write of its own (a no-op update
// of the map's row, whose COMMIT waits for the standby, which receives WAL in order).
//
// Thread safety: thread safe (a pool of connections).
#ifndef SKIMAP_STORAGE_POSTGRES_MAP_STORE_H_
#define SKIMAP_STORAGE_POSTGRES_MAP_STORE_H_

#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
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
    // How long a call keeps reconnecting (and an append waits for a synchronous standby)
    // before it answers Unavailable.
    absl::Duration failover_timeout = absl::Seconds(30);
    // A statement without an answer for this long costs its connection (postgres.h).
    absl::Duration statement_timeout = absl::Seconds(5);
    // Appends acknowledge only once a synchronous standby has the record; Open refuses a
    // server not configured for synchronous replication (FailedPrecondition).
    bool require_synchronous_standby = false;
  };
  // What the store has seen of its database (skimapd's /metrics).
  struct Health {
    uint64_t reconnects = 0;             // connections re-established after a loss
    uint64_t unknown_commits = 0;        // COMMITs of non-idempotent writes whose answer was lost
    uint64_t unknown_committed = 0;      // ... that had committed (read back)
    uint64_t unknown_not_committed = 0;  // ... that had not
    uint64_t unknown_unresolved = 0;     // ... that could not be settled within the budget
    uint64_t standby_waits = 0;          // appends held back for want of a synchronous standby
    int synchronous = -1;                // the primary replicates synchronously: 1, 0, -1 unknown
    std::string server;                  // host:port of the last successful write
  };
  Health health() const;
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
  PostgresMapStore(std::unique_ptr<PgPool> pool, const Options& options,
                   std::shared_ptr<std::atomic<uint64_t>> reconnects)
      : options_(options), pool_(std::move(pool)), reconnects_(std::move(reconnects)) {}
  // Runs fn in one transaction on a pooled connection and commits if fn succeeds, then
  // runs after_commit (if any) on the same connection; again from the start (up to 5
  // times) when it meets a serialization failure or a deadlock, and after a reconnect,
  // with backoff within failover_timeout, when the connection is lost, a lock wait times
  // out, or fn or after_commit answer NoSynchronousStandby(). A COMMIT whose answer was
  // lost is counted; fn's next run must settle it (see above).
  template <class T>
  absl::StatusOr<T> InTransaction(
      std::string_view mode, const std::function<absl::StatusOr<T>(PgConnection&)>& fn,
      const std::function<absl::Status(PgConnection&)>& after_commit = nullptr);
  absl::Status InTransaction(const std::function<absl::Status(PgConnection&)>& fn);
  // Runs fn (reads, no transaction) on a pooled connection, again after a reconnect as
  // InTransaction does.
  template <class T>
  absl::StatusOr<T> WithConnection(const std::function<absl::StatusOr<T>(PgConnection&)>& fn);
  static absl::Status NoSynchronousStandby();
  static absl::Status NoMap(const std::string& id);
  static int64_t Clamp(size_t v);  // for a BIGINT parameter
  // Sleeps the next backoff step; false (no sleep) once `deadline` would pass.
  static bool Backoff(absl::Time deadline, absl::Duration* step);
  enum class Outcome { kLost, kCommitted, kNotCommitted, kUnresolved };
  void Count(Outcome o);
  // Fleet nodes: FailedPrecondition unless the lease of `id` names this node with the
  // token it holds (the row is locked FOR SHARE until the transaction ends). OK otherwise.
  absl::Status CheckFence(PgConnection& c, const std::string& id);
  // The map's row; `lock`: FOR UPDATE (waits for a transaction writing it).
  absl::StatusOr<StoredMap> GetMapOn(PgConnection& c, const std::string& id, bool lock = false);
  absl::Status Insert(const std::string& id, const std::string& options, uint64_t last_position,
                      bool importing);
  // Pages of the latest snapshot in key order from `after`; returns the covered position.
  absl::StatusOr<uint64_t> ReadChunks(const std::string& id, std::optional<ChunkKey> after,
                                      size_t limit,
                                      const std::function<absl::Status(const Chunk&)>& fn);
  void SetFence(const std::string& id, int64_t token, Clock::time_point valid_until);
  void DropFence(const std::string& id);

  // An append whose COMMIT's outcome is not known (answer lost, or committed before a
  // synchronous standby was confirmed): its last position and its records.
  struct PendingAppend {
    uint64_t last = 0;
    std::vector<JournalRecord> records;
  };
  // Whether `append` committed: its positions hold exactly its records. REQUIRES: the
  // map's row is locked in c's transaction (so no transaction of ours is still writing).
  absl::StatusOr<bool> Committed(PgConnection& c, const std::string& id,
                                 const PendingAppend& append);
  // Settles the map's unsettled appends and `attempt` (this call's lost one, or null),
  // dropping those that did not commit; the position of a committed one with `records`.
  // REQUIRES: as Committed.
  absl::StatusOr<std::optional<uint64_t>> Settle(PgConnection& c, const std::string& id,
                                                 const std::vector<JournalRecord>& records,
                                                 const PendingAppend* attempt);
  // Forgets the unsettled appends of map `id` (deleted or created anew).
  void ForgetPending(const std::string& id);

  const Options options_;
  std::unique_ptr<PgPool> pool_;
  const std::shared_ptr<std::atomic<uint64_t>> reconnects_;  // the pool's connections'
  mutable Mutex health_mu_;
  Health health_ ABSL_GUARDED_BY(health_mu_);
  // Appends left unsettled when their call gave up, per map, settled by the map's next
  // append; the committed ones stay until a re-send matches them (at most 16 per map).
  std::map<std::string, std::vector<PendingAppend>> unresolved_ ABSL_GUARDED_BY(health_mu_);
  Mutex fence_mu_;
  std::map<std::string, Held> fences_ ABSL_GUARDED_BY(fence_mu_);  // leases this node holds
};

template <class T>
absl::StatusOr<T> PostgresMapStore::InTransaction(
    std::string_view mode, const std::function<absl::StatusOr<T>(PgConnection&)>& fn,
    const std::function<absl::Status(PgConnection&)>& after_commit) {
  constexpr int kAttempts = 5;  // serialization failures and deadlocks
  const absl::Time deadline = absl::Now() + options_.failover_timeout;
  absl::Duration step = absl::Milliseconds(50);
  std::optional<PgPool::Lease> c;
  absl::StatusOr<T> result = absl::UnknownError("not run");
  for (int serialization = 0;;) {
    if (!c.has_value()) c.emplace(pool_->Take());
    PgConnection& conn = **c;
    if (!conn.healthy()) {
      if (absl::Status s = conn.Reset(); !s.ok()) {
        c.reset();  // not held while waiting
        if (!Backoff(deadline, &step)) return s;
        continue;
      }
    }
    {
      PgTransaction tx(conn, mode);
      if (!tx.status().ok()) {
        result = tx.status();
      } else {
        result = fn(conn);
        if (result.ok()) {
          absl::Status committed = tx.Commit();
          if (!committed.ok()) {
            result = committed;
            if (IsConnectionLost(committed)) Count(Outcome::kLost);
          } else if (after_commit != nullptr) {
            if (absl::Status s = after_commit(conn); !s.ok()) result = s;
          }
        }
      }
    }
    if (result.ok()) return result;
    if (IsRetryable(result.status())) {
      if (++serialization < kAttempts) continue;
      return result;
    }
    if (!IsConnectionLost(result.status())) return result;
    c.reset();  // not held while waiting
    if (!Backoff(deadline, &step)) return result;
  }
}

template <class T>
absl::StatusOr<T> PostgresMapStore::WithConnection(
    const std::function<absl::StatusOr<T>(PgConnection&)>& fn) {
  const absl::Time deadline = absl::Now() + options_.failover_timeout;
  absl::Duration step = absl::Milliseconds(50);
  for (;;) {
    absl::StatusOr<T> result = absl::UnknownError("not run");
    {
      PgPool::Lease c = pool_->Take();
      if (!c->healthy()) {
        if (absl::Status s = c->Reset(); !s.ok()) result = s;
      }
      if (c->healthy()) result = fn(*c);
    }
    if (result.ok() || !IsConnectionLost(result.status()) || !Backoff(deadline, &step)) {
      return result;
    }
  }
}

}  // namespace skimap::storage

#endif  // SKIMAP_STORAGE_POSTGRES_MAP_STORE_H_
