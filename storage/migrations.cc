#include "storage/migrations.h"

#include "absl/strings/str_cat.h"

namespace skimap::storage {

absl::StatusOr<int> SchemaVersion(Database& db) {
  if (absl::Status s = db.Exec("CREATE TABLE IF NOT EXISTS schema_version ("
                               " version INTEGER PRIMARY KEY, name TEXT NOT NULL,"
                               " applied_unix_s INTEGER NOT NULL DEFAULT (strftime('%s','now')));");
      !s.ok()) {
    return s;
  }
  absl::StatusOr<Statement> st = db.Prepare("SELECT COALESCE(MAX(version), 0) FROM schema_version");
  if (!st.ok()) return st.status();
  absl::StatusOr<bool> row = st->Step();
  if (!row.ok()) return row.status();
  return static_cast<int>(st->ColumnInt(0));
}

absl::Status Migrate(Database& db, std::span<const Migration> migrations) {
  for (size_t i = 0; i < migrations.size(); ++i) {
    if (migrations[i].version != static_cast<int>(i) + 1) {
      return absl::FailedPreconditionError(absl::StrCat("migrations: version ",
                                                        migrations[i].version, " at position ", i,
                                                        " (want consecutive versions from 1)"));
    }
  }
  absl::StatusOr<int> current = SchemaVersion(db);
  if (!current.ok()) return current.status();
  const int newest = static_cast<int>(migrations.size());
  if (*current > newest) {
    return absl::FailedPreconditionError(absl::StrCat(db.path(), ": schema version ", *current,
                                                      " is newer than this build's ", newest,
                                                      " (written by newer software)"));
  }
  for (int v = *current + 1; v <= newest; ++v) {
    const Migration& m = migrations[v - 1];
    Transaction tx(db);
    if (!tx.status().ok()) return tx.status();
    if (absl::Status s = db.Exec(m.sql); !s.ok()) {
      return absl::Status(
          s.code(), absl::StrCat("migration ", v, " (", std::string(m.name), "): ", s.message()));
    }
    absl::StatusOr<Statement> st =
        db.Prepare("INSERT INTO schema_version(version, name) VALUES (?, ?)");
    if (!st.ok()) return st.status();
    if (absl::Status s = st->BindInt(1, v); !s.ok()) return s;
    if (absl::Status s = st->BindText(2, m.name); !s.ok()) return s;
    if (absl::Status s = st->Run(); !s.ok()) return s;
    if (absl::Status s = tx.Commit(); !s.ok()) return s;
  }
  return absl::OkStatus();
}

}  // namespace skimap::storage
