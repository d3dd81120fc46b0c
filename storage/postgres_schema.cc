#include "storage/postgres_schema.h"

#include <string_view>

#include "absl/strings/str_cat.h"

namespace skimap::storage {
namespace {

// Version 1: the map store (as maps.sqlite v2) and the fleet's membership and leases.
// Chunk volumes compare as bytes (COLLATE "C"), the key order of map_store.h.
constexpr char kV1[] = R"sql(
CREATE TABLE maps (
  id TEXT PRIMARY KEY,
  options BYTEA NOT NULL,
  last_position BIGINT NOT NULL DEFAULT 0,
  snapshot_position BIGINT NOT NULL DEFAULT 0,
  snapshot_unix_ms BIGINT NOT NULL DEFAULT 0,
  importing BOOLEAN NOT NULL DEFAULT FALSE
);
CREATE TABLE journal (
  map TEXT NOT NULL REFERENCES maps(id) ON DELETE CASCADE,
  position BIGINT NOT NULL,
  kind BIGINT NOT NULL,
  payload BYTEA NOT NULL,
  PRIMARY KEY (map, position)
);
CREATE TABLE chunks (
  map TEXT NOT NULL REFERENCES maps(id) ON DELETE CASCADE,
  volume TEXT COLLATE "C" NOT NULL,
  cx BIGINT NOT NULL,
  cy BIGINT NOT NULL,
  cz BIGINT NOT NULL,
  bytes BYTEA NOT NULL,
  PRIMARY KEY (map, volume, cx, cy, cz)
);
CREATE TABLE nodes (
  id TEXT PRIMARY KEY,
  address TEXT NOT NULL,
  started_unix_ms BIGINT NOT NULL,
  heartbeat_unix_ms BIGINT NOT NULL,
  ttl_ms BIGINT NOT NULL
);
CREATE TABLE leases (
  map TEXT PRIMARY KEY REFERENCES maps(id) ON DELETE CASCADE,
  node TEXT NOT NULL,
  token BIGINT NOT NULL,
  expires_unix_ms BIGINT NOT NULL
);
)sql";

struct PgMigration {
  int version;
  const char* name;
  const char* sql;
};
constexpr PgMigration kPgMigrations[] = {
    {1, "map store (maps, journal, chunks) and fleet (nodes, leases)", kV1},
};

absl::StatusOr<int> Version(PgConnection& c) {
  absl::StatusOr<PgResult> r =
      c.Exec("SELECT COALESCE(MAX(version), 0)::BIGINT FROM schema_version");
  if (!r.ok()) return r.status();
  return int(r->Int(0, 0));
}

}  // namespace

absl::Status MigratePostgres(PgConnection& c) {
  absl::Status created = c.ExecScript(
      "CREATE TABLE IF NOT EXISTS schema_version (version BIGINT PRIMARY KEY, name TEXT NOT "
      "NULL, applied_unix_ms BIGINT NOT NULL)");
  // Two nodes creating it at once: one of them meets a unique violation in the catalog.
  if (!created.ok() && !absl::IsAlreadyExists(created)) return created;
  const int newest = int(std::size(kPgMigrations));
  for (;;) {
    absl::StatusOr<int> current = Version(c);
    if (!current.ok()) return current.status();
    if (*current > newest) {
      return absl::FailedPreconditionError(absl::StrCat("postgres store: schema version ", *current,
                                                        " is newer than this build's ", newest,
                                                        " (written by newer software)"));
    }
    if (*current == newest) return absl::OkStatus();
    const PgMigration& m = kPgMigrations[*current];
    auto apply = [&]() -> absl::Status {
      PgTransaction tx(c);
      if (!tx.status().ok()) return tx.status();
      if (absl::Status s = c.ExecScript(m.sql); !s.ok()) return s;
      PgParams p;
      p.Int(m.version).Text(m.name);
      absl::StatusOr<PgResult> r =
          c.Exec(absl::StrCat("INSERT INTO schema_version VALUES ($1, $2, ", kPgNowMs, ")"), p);
      if (!r.ok()) return r.status();
      return tx.Commit();
    };
    const absl::Status s = apply();  // rolled back unless committed
    if (s.ok()) continue;
    // Another node applied this step meanwhile: its version row (or a table) exists.
    absl::StatusOr<int> again = Version(c);
    if (again.ok() && *again > *current) continue;
    return absl::Status(s.code(), absl::StrCat("postgres store: migration ", m.version, " (",
                                               m.name, "): ", s.message()));
  }
}

}  // namespace skimap::storage
