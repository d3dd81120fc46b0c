// The PostgreSQL store's schema and its migrations (docs/formats.md, "PostgreSQL store"),
// recorded in a schema_version table like the SQLite files.
//
// Thread safety: one connection, one thread. Nodes that start together may migrate at
// once: the loser of a race on a step sees the winner's version and goes on.
#ifndef SKIMAP_STORAGE_POSTGRES_SCHEMA_H_
#define SKIMAP_STORAGE_POSTGRES_SCHEMA_H_

#include "absl/status/status.h"
#include "storage/postgres.h"

namespace skimap::storage {

// The database clock in Unix milliseconds, as an SQL expression.
inline constexpr char kPgNowMs[] = "(EXTRACT(EPOCH FROM clock_timestamp()) * 1000)::BIGINT";

// Applies the missing migrations, each in its own transaction. FailedPrecondition if the
// database was migrated by newer software; the server's error otherwise.
absl::Status MigratePostgres(PgConnection& c);

}  // namespace skimap::storage

#endif  // SKIMAP_STORAGE_POSTGRES_SCHEMA_H_
