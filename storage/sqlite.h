// A small RAII layer over the sqlite3 C API: Database (one connection), Statement (one
// prepared statement), Transaction (rolls back unless committed). Errors are absl::Status
// values carrying SQLite's message; nothing throws.
//
//   absl::StatusOr<std::unique_ptr<Database>> db = Database::Open("objects.db");
//   absl::StatusOr<Statement> st = (*db)->Prepare("SELECT name FROM objects WHERE obj_id = ?");
//   st->BindInt(1, 3);
//   while (*st->Step()) std::string name = st->ColumnText(0);
//
// Thread safety: a Database and its Statements belong to one thread at a time (callers
// serialize, e.g. ObjectStore holds a mutex). The connection is opened in SQLite's
// multi-thread mode.
#ifndef SKIMAP_STORAGE_SQLITE_H_
#define SKIMAP_STORAGE_SQLITE_H_

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>

#include "absl/status/statusor.h"

struct sqlite3;
struct sqlite3_stmt;

namespace skimap::storage {

class Statement {
 public:
  Statement(Statement&& o) noexcept : db_(o.db_), stmt_(o.stmt_) { o.stmt_ = nullptr; }
  Statement& operator=(Statement&& o) noexcept;
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;
  ~Statement();

  // Parameter binding; index is 1-based (SQLite). Values are copied.
  absl::Status BindInt(int index, int64_t value);
  absl::Status BindDouble(int index, double value);
  absl::Status BindText(int index, std::string_view value);
  absl::Status BindBlob(int index, std::string_view value);
  // A blob SQLite reads in place instead of copying (a journal record of a megabyte).
  // REQUIRES: `value` outlives the statement's next Reset or its destruction.
  absl::Status BindBlobInPlace(int index, std::string_view value);

  // Runs one step: true if a row is available, false when done.
  absl::StatusOr<bool> Step();
  // Runs to completion (for statements that return no rows).
  absl::Status Run();
  // Resets for another execution (bindings cleared).
  void Reset();

  // Columns of the current row (0-based). REQUIRES: the last Step() returned true.
  int64_t ColumnInt(int col) const;
  double ColumnDouble(int col) const;
  std::string ColumnText(int col) const;
  std::string ColumnBlob(int col) const;
  bool ColumnIsNull(int col) const;

 private:
  friend class Database;
  Statement(sqlite3* db, sqlite3_stmt* stmt) : db_(db), stmt_(stmt) {}
  absl::Status Check(int rc, std::string_view what) const;

  sqlite3* db_;
  sqlite3_stmt* stmt_;
};

class Database {
 public:
  // Opens (creating if missing) the database file at `path` with foreign keys on and a
  // 5 s busy timeout. ":memory:" gives an in-memory database. Unavailable on failure.
  static absl::StatusOr<std::unique_ptr<Database>> Open(const std::string& path);
  ~Database();
  Database(const Database&) = delete;
  Database& operator=(const Database&) = delete;

  // Runs one or more SQL statements that return no rows.
  absl::Status Exec(std::string_view sql);
  // Prepares one statement.
  absl::StatusOr<Statement> Prepare(std::string_view sql);
  const std::string& path() const { return path_; }

 private:
  Database(sqlite3* db, std::string path) : db_(db), path_(std::move(path)) {}
  sqlite3* db_;
  std::string path_;
};

// BEGIN IMMEDIATE on construction; ROLLBACK on destruction unless Commit() succeeded.
class Transaction {
 public:
  // Starts a transaction (check status() before use).
  explicit Transaction(Database& db);
  ~Transaction();
  Transaction(const Transaction&) = delete;
  Transaction& operator=(const Transaction&) = delete;

  const absl::Status& status() const { return status_; }
  absl::Status Commit();

 private:
  Database& db_;
  absl::Status status_;
  bool open_ = false;
};

}  // namespace skimap::storage

#endif  // SKIMAP_STORAGE_SQLITE_H_
