// Schema versioning: a `schema_version` table records every migration applied; Migrate()
// applies the missing ones in order, each in its own transaction, so a database file is
// always at a well-defined version. The storage schema's migrations are in schema.h.
//
// Thread safety: as Database (one thread at a time per connection).
#ifndef SKIMAP_STORAGE_MIGRATIONS_H_
#define SKIMAP_STORAGE_MIGRATIONS_H_

#include <span>
#include <string_view>

#include "absl/status/statusor.h"
#include "storage/sqlite.h"

namespace skimap::storage {

// One step of the schema: version v turns a database at version v - 1 into version v.
struct Migration {
  int version = 0;        // 1, 2, 3, ... consecutive
  std::string_view name;  // short description, stored in schema_version
  std::string_view sql;   // statements run in one transaction
};

// The version of the database (0 for a fresh file without schema_version).
absl::StatusOr<int> SchemaVersion(Database& db);

// Applies every migration newer than the database's version. FailedPrecondition if the
// database is newer than the newest migration (written by newer software) or the list is
// not consecutive from 1; errors of SQLite otherwise (the failing step is rolled back).
absl::Status Migrate(Database& db, std::span<const Migration> migrations);

}  // namespace skimap::storage

#endif  // SKIMAP_STORAGE_MIGRATIONS_H_
