// PostgresMapStore: the LeaseStore calls (membership, leases, fences).
#include <set>
#include <utility>

#include "absl/strings/str_cat.h"
#include "storage/postgres_map_store.h"
#include "storage/postgres_schema.h"
#include "storage/status_macros.h"

namespace skimap::storage {
namespace {

absl::Status NotANode() {
  return absl::FailedPreconditionError("map store: opened without a node id (not a fleet node)");
}

// Lease columns joined with the holder's address; `live` by the database clock.
constexpr char kLeaseSelect[] =
    "SELECT l.map, l.node, COALESCE(n.address, ''), l.token, l.expires_unix_ms > "
    "(EXTRACT(EPOCH FROM clock_timestamp()) * 1000)::BIGINT FROM leases l LEFT JOIN nodes n ON "
    "n.id = l.node";

Lease LeaseAt(const PgResult& r, int row) {
  return Lease{r.Bytes(row, 0), r.Bytes(row, 1), r.Bytes(row, 2), r.Int(row, 3), r.Bool(row, 4)};
}

}  // namespace

void PostgresMapStore::SetFence(const std::string& id, int64_t token,
                                Clock::time_point valid_until) {
  MutexLock lock(&fence_mu_);
  fences_[id] = Held{token, valid_until};
}

void PostgresMapStore::DropFence(const std::string& id) {
  MutexLock lock(&fence_mu_);
  fences_.erase(id);
}

std::optional<LeaseStore::Held> PostgresMapStore::HeldLease(const std::string& id) {
  MutexLock lock(&fence_mu_);
  auto it = fences_.find(id);
  if (it == fences_.end() || it->second.valid_until <= Clock::now()) return std::nullopt;
  return it->second;
}

absl::StatusOr<std::vector<std::string>> PostgresMapStore::Heartbeat(const std::string& address,
                                                                     absl::Duration ttl) {
  if (options_.node_id.empty()) return NotANode();
  const int64_t ttl_ms = absl::ToInt64Milliseconds(ttl);
  const Clock::time_point start = Clock::now();
  // Fences taken from here on are not judged by this renewal.
  std::map<std::string, Held> before;
  {
    MutexLock lock(&fence_mu_);
    before = fences_;
  }
  using Renewed = std::set<std::pair<std::string, int64_t>>;
  absl::StatusOr<Renewed> renewed =
      InTransaction<Renewed>("", [&](PgConnection& c) -> absl::StatusOr<Renewed> {
        PgParams p;
        p.Text(options_.node_id).Text(address).Int(ttl_ms);
        SK_RETURN_IF_ERROR(
            c.Exec(absl::StrCat("INSERT INTO nodes (id, address, started_unix_ms, "
                                "heartbeat_unix_ms, ttl_ms) VALUES ($1, $2, ",
                                kPgNowMs, ", ", kPgNowMs,
                                ", $3) ON CONFLICT (id) DO UPDATE SET address = "
                                "EXCLUDED.address, heartbeat_unix_ms = EXCLUDED.heartbeat_unix_ms, "
                                "ttl_ms = EXCLUDED.ttl_ms"),
                   p)
                .status());
        PgParams q;
        q.Text(options_.node_id).Int(ttl_ms);
        SK_ASSIGN_OR_RETURN(r, c.Exec(absl::StrCat("UPDATE leases SET expires_unix_ms = ", kPgNowMs,
                                                   " + $2 WHERE node = $1 RETURNING map, token"),
                                      q));
        Renewed out;
        for (int i = 0; i < r.rows(); ++i) out.emplace(r.Bytes(i, 0), r.Int(i, 1));
        return out;
      });
  if (!renewed.ok()) return renewed.status();
  std::vector<std::string> lost;
  MutexLock lock(&fence_mu_);
  for (const auto& [id, held] : before) {
    auto it = fences_.find(id);
    if (it == fences_.end() || it->second.token != held.token) continue;  // changed meanwhile
    if (renewed->contains({id, held.token})) {
      it->second.valid_until =
          std::max(it->second.valid_until, start + ttl_ms * std::chrono::milliseconds(1));
    } else {
      fences_.erase(it);
      lost.push_back(id);
    }
  }
  return lost;
}

absl::Status PostgresMapStore::Leave() {
  if (options_.node_id.empty()) return NotANode();
  {
    MutexLock lock(&fence_mu_);
    fences_.clear();
  }
  return InTransaction([&](PgConnection& c) -> absl::Status {
    PgParams p;
    p.Text(options_.node_id);
    SK_RETURN_IF_ERROR(c.Exec("UPDATE leases SET expires_unix_ms = 0 WHERE node = $1", p).status());
    return c.Exec("DELETE FROM nodes WHERE id = $1", p).status();
  });
}

absl::StatusOr<std::vector<NodeInfo>> PostgresMapStore::ListNodes(absl::Duration forget_after) {
  return WithConnection<std::vector<NodeInfo>>(
      [&](PgConnection& c) -> absl::StatusOr<std::vector<NodeInfo>> {
        PgParams p;
        p.Int(absl::ToInt64Milliseconds(forget_after));
        SK_RETURN_IF_ERROR(
            c.Exec(absl::StrCat("DELETE FROM nodes WHERE heartbeat_unix_ms < ", kPgNowMs, " - $1"),
                   p)
                .status());
        SK_ASSIGN_OR_RETURN(
            r, c.Exec(absl::StrCat("SELECT id, address, started_unix_ms, heartbeat_unix_ms, "
                                   "heartbeat_unix_ms + ttl_ms > ",
                                   kPgNowMs, " FROM nodes ORDER BY id")));
        std::vector<NodeInfo> out;
        for (int i = 0; i < r.rows(); ++i) {
          out.push_back({r.Bytes(i, 0), r.Bytes(i, 1), r.Int(i, 2), r.Int(i, 3), r.Bool(i, 4)});
        }
        return out;
      });
}

absl::StatusOr<Lease> PostgresMapStore::AcquireLease(const std::string& id, absl::Duration ttl) {
  if (options_.node_id.empty()) return NotANode();
  const Clock::time_point start = Clock::now();
  absl::StatusOr<Lease> lease =
      InTransaction<Lease>("", [&](PgConnection& c) -> absl::StatusOr<Lease> {
        SK_RETURN_IF_ERROR(GetMapOn(c, id).status());
        PgParams p;
        p.Text(id).Text(options_.node_id).Int(absl::ToInt64Milliseconds(ttl));
        // Taken when free or expired; renewed (same token) when this node holds it. A new
        // holder gets the next token, which fences the writes of every earlier one.
        SK_ASSIGN_OR_RETURN(
            r,
            c.Exec(
                absl::StrCat(
                    "INSERT INTO leases AS l (map, node, token, expires_unix_ms) VALUES ($1, $2, "
                    "1, ",
                    kPgNowMs,
                    " + $3) ON CONFLICT (map) DO UPDATE SET token = CASE WHEN l.node = "
                    "EXCLUDED.node THEN l.token ELSE l.token + 1 END, node = EXCLUDED.node, "
                    "expires_unix_ms = EXCLUDED.expires_unix_ms WHERE l.node = EXCLUDED.node OR "
                    "l.expires_unix_ms <= ",
                    kPgNowMs, " RETURNING l.token"),
                p));
        if (r.rows() == 1) return Lease{id, options_.node_id, "", r.Int(0, 0), true};
        PgParams q;
        q.Text(id);
        SK_ASSIGN_OR_RETURN(held, c.Exec(absl::StrCat(kLeaseSelect, " WHERE l.map = $1"), q));
        if (held.rows() == 0) return absl::NotFoundError(absl::StrCat("map store: no map ", id));
        return LeaseAt(held, 0);
      });
  if (lease.ok() && lease->node == options_.node_id) {
    SetFence(id, lease->token, start + absl::ToChronoNanoseconds(ttl));
  }
  return lease;
}

absl::StatusOr<std::vector<Lease>> PostgresMapStore::ListLeases() {
  return WithConnection<std::vector<Lease>>(
      [&](PgConnection& c) -> absl::StatusOr<std::vector<Lease>> {
        SK_ASSIGN_OR_RETURN(r, c.Exec(absl::StrCat(kLeaseSelect, " ORDER BY l.map")));
        std::vector<Lease> out;
        for (int i = 0; i < r.rows(); ++i) out.push_back(LeaseAt(r, i));
        return out;
      });
}

}  // namespace skimap::storage
