// PostgresMapStore: the maps and their snapshots. The journal calls are in
// postgres_journal.cc, the lease calls in postgres_leases.cc.
#include "storage/postgres_map_store.h"

#include <algorithm>
#include <climits>
#include <optional>

#include "absl/strings/str_cat.h"
#include "storage/postgres_schema.h"
#include "storage/status_macros.h"

namespace skimap::storage {
namespace {

constexpr char kPgMapColumns[] =
    "id, options, last_position, snapshot_position, snapshot_unix_ms, importing";
constexpr size_t kPage = 256;  // chunks per query when reading a whole snapshot

StoredMap MapAt(const PgResult& r, int row) {
  return StoredMap{r.Bytes(row, 0),         r.Bytes(row, 1), uint64_t(r.Int(row, 2)),
                   uint64_t(r.Int(row, 3)), r.Int(row, 4),   r.Bool(row, 5)};
}

}  // namespace

absl::StatusOr<std::unique_ptr<PostgresMapStore>> PostgresMapStore::Open(const std::string& dsn,
                                                                         const Options& options) {
  // A node paused inside a transaction (SIGSTOP, a partition) holds its row locks, the
  // lease row's among them, and would keep the other nodes from taking its maps over: the
  // server ends such a session after a lease time (the node's next statement then fails,
  // and nothing of the transaction commits).
  const int64_t idle_ms =
      options.node_id.empty()
          ? 60000
          : std::max<int64_t>(1000, absl::ToInt64Milliseconds(options.lease_ttl));
  auto reconnects = std::make_shared<std::atomic<uint64_t>>(0);
  SK_ASSIGN_OR_RETURN(
      pool,
      PgPool::Open(dsn, options.connections,
                   {.setup = absl::StrCat("SET idle_in_transaction_session_timeout = ", idle_ms),
                    .statement_timeout = options.statement_timeout,
                    .reconnects = reconnects}));
  {
    PgPool::Lease c = pool->Take();
    SK_RETURN_IF_ERROR(MigratePostgres(*c));
    if (options.require_synchronous_standby) {
      SK_ASSIGN_OR_RETURN(r, c->Exec("SELECT current_setting('synchronous_standby_names')"));
      if (r.Bytes(0, 0).empty()) {
        return absl::FailedPreconditionError(absl::StrCat(
            "map store: the PostgreSQL primary at ", c->server(),
            " does not replicate synchronously (synchronous_standby_names is empty): an "
            "acknowledged frame would be on one database node only. Configure synchronous "
            "replication (docs/operations.md, \"A replicated store\") or accept one node "
            "(skimapd --store_durability=primary)"));
      }
    }
  }
  return std::unique_ptr<PostgresMapStore>(
      new PostgresMapStore(std::move(pool), options, std::move(reconnects)));
}

PostgresMapStore::Health PostgresMapStore::health() const {
  MutexLock lock(&health_mu_);
  Health h = health_;
  h.reconnects = reconnects_->load();
  return h;
}

void PostgresMapStore::Count(Outcome o) {
  MutexLock lock(&health_mu_);
  switch (o) {
    case Outcome::kLost:
      ++health_.unknown_commits;
      break;
    case Outcome::kCommitted:
      ++health_.unknown_committed;
      break;
    case Outcome::kNotCommitted:
      ++health_.unknown_not_committed;
      break;
    case Outcome::kUnresolved:
      ++health_.unknown_unresolved;
      break;
  }
}

bool PostgresMapStore::Backoff(absl::Time deadline, absl::Duration* step) {
  if (absl::Now() + *step > deadline) return false;
  absl::SleepFor(*step);
  *step = std::min(*step * 2, absl::Seconds(1));
  return true;
}

absl::Status PostgresMapStore::NoMap(const std::string& id) {
  return absl::NotFoundError(absl::StrCat("map store: no map ", id));
}

int64_t PostgresMapStore::Clamp(size_t v) { return int64_t(std::min<size_t>(v, INT64_MAX)); }

absl::Status PostgresMapStore::NoSynchronousStandby() {
  return absl::UnavailableError(
      "map store: the PostgreSQL primary has no synchronous standby (synchronous_standby_names "
      "is empty): not acknowledged until one is attached");
}

absl::Status PostgresMapStore::InTransaction(const std::function<absl::Status(PgConnection&)>& fn) {
  return InTransaction<bool>("",
                             [&](PgConnection& c) -> absl::StatusOr<bool> {
                               SK_RETURN_IF_ERROR(fn(c));
                               return true;
                             })
      .status();
}

absl::Status PostgresMapStore::CheckFence(PgConnection& c, const std::string& id) {
  if (options_.node_id.empty()) return absl::OkStatus();
  int64_t token = 0;
  {
    MutexLock lock(&fence_mu_);
    auto it = fences_.find(id);
    if (it == fences_.end()) {
      return absl::FailedPreconditionError(absl::StrCat(
          "map store: node ", options_.node_id, " holds no lease on map ", id, "; not written"));
    }
    token = it->second.token;
  }
  // FOR SHARE: a node taking the lease over (UPDATE of this row) waits for this
  // transaction, and this one waits for it: the takeover sees every write let through.
  PgParams p;
  p.Text(id);
  SK_ASSIGN_OR_RETURN(r, c.Exec("SELECT node, token FROM leases WHERE map = $1 FOR SHARE", p));
  if (r.rows() == 1 && r.Bytes(0, 0) == options_.node_id && r.Int(0, 1) == token) {
    return absl::OkStatus();
  }
  DropFence(id);
  return absl::FailedPreconditionError(absl::StrCat(
      "map store: node ", options_.node_id, " lost the lease on map ", id, " (fencing token ",
      token,
      r.rows() == 1 ? absl::StrCat("; now node ", r.Bytes(0, 0), ", token ", r.Int(0, 1))
                    : std::string("; lease gone"),
      "); not written"));
}

absl::StatusOr<StoredMap> PostgresMapStore::GetMapOn(PgConnection& c, const std::string& id,
                                                     bool lock) {
  PgParams p;
  p.Text(id);
  SK_ASSIGN_OR_RETURN(r, c.Exec(absl::StrCat("SELECT ", kPgMapColumns, " FROM maps WHERE id = $1",
                                             lock ? " FOR UPDATE" : ""),
                                p));
  if (r.rows() == 0) return NoMap(id);
  return MapAt(r, 0);
}

absl::Status PostgresMapStore::CreateMap(const std::string& id, const std::string& options) {
  return Insert(id, options, 0, false);
}

absl::Status PostgresMapStore::BeginImport(const std::string& id, const std::string& options,
                                           uint64_t journal_base) {
  return Insert(id, options, journal_base, true);
}

absl::Status PostgresMapStore::Insert(const std::string& id, const std::string& options,
                                      uint64_t last_position, bool importing) {
  if (id.empty()) return absl::InvalidArgumentError("map store: empty map id");
  if (last_position > uint64_t(INT64_MAX)) {
    return absl::InvalidArgumentError("map store: journal base beyond 2^63");
  }
  const Clock::time_point start = Clock::now();
  bool attempted = false;  // an earlier attempt reached COMMIT (its answer may be lost)
  absl::Status s = InTransaction([&](PgConnection& c) -> absl::Status {
    PgParams p;
    p.Text(id).Bytes(options).Int(int64_t(last_position)).Bool(importing);
    // ON CONFLICT DO NOTHING: a conflict leaves the transaction usable for the check below.
    SK_ASSIGN_OR_RETURN(r, c.Exec("INSERT INTO maps (id, options, last_position, importing) "
                                  "VALUES ($1, $2, $3, $4) ON CONFLICT (id) DO NOTHING",
                                  p));
    if (r.affected() == 0) {
      // The conflict waited for the row's writer: the map as this call's lost attempt would
      // have made it (with this node's first lease) is that attempt's.
      if (attempted) {
        SK_ASSIGN_OR_RETURN(map, GetMapOn(c, id));
        bool ours = map.options == options && map.importing == importing;
        if (ours && !options_.node_id.empty()) {
          PgParams l;
          l.Text(id);
          SK_ASSIGN_OR_RETURN(lease, c.Exec("SELECT node, token FROM leases WHERE map = $1", l));
          ours = lease.rows() == 1 && lease.Bytes(0, 0) == options_.node_id && lease.Int(0, 1) == 1;
        }
        if (ours) return absl::OkStatus();
      }
      return absl::AlreadyExistsError(absl::StrCat("map store: map ", id, " exists"));
    }
    if (!options_.node_id.empty()) {
      // A fleet node creates the map holding its lease.
      PgParams l;
      l.Text(id).Text(options_.node_id).Int(absl::ToInt64Milliseconds(options_.lease_ttl));
      SK_RETURN_IF_ERROR(
          c.Exec(absl::StrCat("INSERT INTO leases (map, node, token, expires_unix_ms) VALUES ($1, "
                              "$2, 1, ",
                              kPgNowMs, " + $3)"),
                 l)
              .status());
    }
    attempted = true;
    return absl::OkStatus();
  });
  if (s.ok()) ForgetPending(id);
  if (s.ok() && !options_.node_id.empty())
    SetFence(id, 1, start + absl::ToChronoNanoseconds(options_.lease_ttl));
  return s;
}

absl::Status PostgresMapStore::FinishImport(const std::string& id) {
  return InTransaction([&](PgConnection& c) -> absl::Status {
    PgParams p;
    p.Text(id);
    SK_ASSIGN_OR_RETURN(r, c.Exec("UPDATE maps SET importing = FALSE WHERE id = $1", p));
    if (r.affected() == 0) return NoMap(id);
    return CheckFence(c, id);
  });
}

absl::Status PostgresMapStore::DeleteMap(const std::string& id) {
  bool attempted = false;  // an earlier attempt reached COMMIT (its answer may be lost)
  absl::Status s = InTransaction([&](PgConnection& c) -> absl::Status {
    // FOR UPDATE waits for a lost attempt still deleting the row: gone after it, it did.
    absl::StatusOr<StoredMap> map = GetMapOn(c, id, /*lock=*/true);
    if (attempted && absl::IsNotFound(map.status())) return absl::OkStatus();
    SK_RETURN_IF_ERROR(map.status());
    SK_RETURN_IF_ERROR(CheckFence(c, id));
    PgParams p;
    p.Text(id);
    // The foreign keys cascade to the journal, the chunks and the lease.
    SK_ASSIGN_OR_RETURN(r, c.Exec("DELETE FROM maps WHERE id = $1", p));
    if (r.affected() == 0) return NoMap(id);
    attempted = true;
    return absl::OkStatus();
  });
  if (s.ok()) {
    DropFence(id);
    ForgetPending(id);
  }
  return s;
}

absl::StatusOr<StoredMap> PostgresMapStore::GetMap(const std::string& id) {
  return WithConnection<StoredMap>([&](PgConnection& c) { return GetMapOn(c, id); });
}

absl::StatusOr<std::vector<StoredMap>> PostgresMapStore::ListMaps() {
  return WithConnection<std::vector<StoredMap>>(
      [&](PgConnection& c) -> absl::StatusOr<std::vector<StoredMap>> {
        SK_ASSIGN_OR_RETURN(
            r, c.Exec(absl::StrCat("SELECT ", kPgMapColumns, " FROM maps ORDER BY id")));
        std::vector<StoredMap> out;
        for (int i = 0; i < r.rows(); ++i) out.push_back(MapAt(r, i));
        return out;
      });
}

absl::Status PostgresMapStore::WriteSnapshot(const std::string& id, uint64_t covers_position,
                                             const std::vector<Chunk>& changed,
                                             const std::vector<ChunkKey>& removed) {
  return InTransaction([&](PgConnection& c) -> absl::Status {
    // The map's row is locked only at the end (appends go on while the chunks are written).
    SK_ASSIGN_OR_RETURN(map, GetMapOn(c, id));
    if (covers_position < map.snapshot_position || covers_position > map.last_position) {
      return absl::InvalidArgumentError(
          absl::StrCat("map store: map ", id, ": a snapshot covering position ", covers_position,
                       " is outside [", map.snapshot_position, ", ", map.last_position, "]"));
    }
    SK_RETURN_IF_ERROR(CheckFence(c, id));
    for (const Chunk& chunk : changed) {
      PgParams p;
      p.Text(id).Text(chunk.key.volume).Int(chunk.key.x).Int(chunk.key.y).Int(chunk.key.z);
      p.Bytes(chunk.bytes);
      SK_RETURN_IF_ERROR(c.Exec("INSERT INTO chunks (map, volume, cx, cy, cz, bytes) VALUES ($1, "
                                "$2, $3, $4, $5, $6) ON CONFLICT (map, volume, cx, cy, cz) DO "
                                "UPDATE SET bytes = EXCLUDED.bytes",
                                p)
                             .status());
    }
    for (const ChunkKey& k : removed) {
      PgParams p;
      p.Text(id).Text(k.volume).Int(k.x).Int(k.y).Int(k.z);
      SK_RETURN_IF_ERROR(c.Exec("DELETE FROM chunks WHERE map = $1 AND volume = $2 AND cx = $3 "
                                "AND cy = $4 AND cz = $5",
                                p)
                             .status());
    }
    PgParams p;
    p.Text(id).Int(int64_t(covers_position));
    SK_ASSIGN_OR_RETURN(
        r, c.Exec(absl::StrCat("UPDATE maps SET snapshot_position = $2, snapshot_unix_ms = ",
                               kPgNowMs, " WHERE id = $1 AND snapshot_position <= $2"),
                  p));
    if (r.affected() != 1) {
      return absl::InvalidArgumentError(absl::StrCat(
          "map store: map ", id, ": a newer snapshot was written meanwhile; not written"));
    }
    return absl::OkStatus();
  });
}

absl::StatusOr<uint64_t> PostgresMapStore::ReadChunks(
    const std::string& id, std::optional<ChunkKey> after, size_t limit,
    const std::function<absl::Status(const Chunk&)>& fn) {
  // One REPEATABLE READ transaction: every page and the position from one snapshot.
  return InTransaction<uint64_t>(
      "ISOLATION LEVEL REPEATABLE READ READ ONLY",
      [&](PgConnection& c) -> absl::StatusOr<uint64_t> {
        SK_ASSIGN_OR_RETURN(map, GetMapOn(c, id));
        while (limit > 0) {
          PgParams p;
          p.Text(id).Int(Clamp(std::min(limit, kPage)));
          if (after.has_value()) p.Text(after->volume).Int(after->x).Int(after->y).Int(after->z);
          SK_ASSIGN_OR_RETURN(
              r, c.Exec(absl::StrCat("SELECT volume, cx, cy, cz, bytes FROM chunks WHERE map = $1",
                                     after.has_value() ? " AND (volume, cx, cy, cz) > ($3, $4, "
                                                         "$5, $6)"
                                                       : "",
                                     " ORDER BY volume, cx, cy, cz LIMIT $2"),
                        p));
          if (r.rows() == 0) break;
          for (int i = 0; i < r.rows(); ++i) {
            Chunk chunk{{r.Bytes(i, 0), r.Int(i, 1), r.Int(i, 2), r.Int(i, 3)}, r.Bytes(i, 4)};
            SK_RETURN_IF_ERROR(fn(chunk));
            after = std::move(chunk.key);
            --limit;
          }
        }
        return map.snapshot_position;
      });
}

absl::StatusOr<uint64_t> PostgresMapStore::ReadSnapshot(
    const std::string& id, const std::function<absl::Status(const Chunk&)>& fn) {
  return ReadChunks(id, std::nullopt, SIZE_MAX, fn);
}

absl::StatusOr<uint64_t> PostgresMapStore::ReadSnapshotPage(
    const std::string& id, const std::optional<ChunkKey>& after, size_t limit,
    const std::function<absl::Status(const Chunk&)>& fn) {
  return ReadChunks(id, after, limit, fn);
}

}  // namespace skimap::storage
