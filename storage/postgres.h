// A small RAII layer over libpq for the PostgreSQL backend: PgConnection (one connection),
// PgResult (one result), PgParams (binary parameters), PgPool (connections shared by the
// threads of one store) and PgTransaction (rolls back unless committed). Every value goes
// and comes in libpq's binary format (int8 big-endian, text and bytea as raw bytes), so
// bytes are kept exactly and nothing is escaped. Errors are absl::Status values carrying
// the server's message and SQLSTATE; nothing throws.
//
//   absl::StatusOr<std::unique_ptr<PgPool>> pool = PgPool::Open("postgres://127.0.0.1/db", 4);
//   PgPool::Lease conn = (*pool)->Take();
//   PgParams p;
//   p.Text("kitchen");
//   absl::StatusOr<PgResult> r = conn->Exec("SELECT options FROM maps WHERE id = $1", p);
//   std::string options = r->Bytes(0, 0);
//
// Status codes: Unavailable (connection lost, server shutting down, a standby that cannot
// write, serialization failure or deadlock: retry), AlreadyExists (unique violation),
// ResourceExhausted (disk full, too many connections), InvalidArgument (bad input),
// Internal otherwise.
//
// A replicated cluster (docs/operations.md, "A replicated store"): a DSN may list several
// hosts (postgresql://u@h1:5432,h2:5432/db). The connection then tries them itself, from
// the one after the host that last failed, and keeps the first that is a primary able to
// commit: not in recovery, and either not configured for synchronous replication or with
// a synchronous standby streaming (an old primary cut off from its standby, whose commits
// would wait forever, is passed over). Every statement has a client-side deadline: a
// server that stops answering (SIGSTOP, a partition) costs the connection, not the thread;
// server side, lock_timeout ends lock waits before it and client_connection_check_interval
// ends sessions whose client went away.
//
// Thread safety: a PgConnection belongs to one thread at a time; PgPool is thread safe.
#ifndef SKIMAP_STORAGE_POSTGRES_H_
#define SKIMAP_STORAGE_POSTGRES_H_

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/time/time.h"

struct pg_conn;
struct pg_result;

namespace skimap::storage {

// Parameters $1, $2, ... in order, in binary format.
class PgParams {
 public:
  PgParams& Int(int64_t v);
  PgParams& Text(std::string_view v);
  PgParams& Bytes(std::string_view v);
  PgParams& Bool(bool v);
  size_t size() const { return values_.size(); }

 private:
  friend class PgConnection;
  std::vector<std::string> values_;
  std::vector<unsigned int> types_;  // OIDs
};

class PgResult {
 public:
  explicit PgResult(pg_result* r) : r_(r) {}
  PgResult(PgResult&& o) noexcept : r_(o.r_) { o.r_ = nullptr; }
  PgResult& operator=(PgResult&& o) noexcept;
  ~PgResult();

  int rows() const;
  // Rows changed by an INSERT / UPDATE / DELETE.
  int64_t affected() const;
  bool IsNull(int row, int col) const;
  // REQUIRES: the column is int8 / int4 / bool (binary), not NULL.
  int64_t Int(int row, int col) const;
  bool Bool(int row, int col) const;
  // Text or bytea, exactly as stored.
  std::string Bytes(int row, int col) const;
  // The command tag ("COMMIT", "ROLLBACK", "INSERT 0 1", ...).
  std::string tag() const;

 private:
  friend class PgConnection;
  pg_result* r_;
};

// How connections reach and keep their server.
struct PgOptions {
  std::string setup;  // SET statements, run after every (re)connect
  // Past this a statement's connection is dropped and the statement is Unavailable.
  absl::Duration statement_timeout = absl::Seconds(10);
  // Counts reconnects that succeeded (Reset, the pool's own included); null: not counted.
  std::shared_ptr<std::atomic<uint64_t>> reconnects;
};

class PgConnection {
 public:
  // Connects to `dsn` (a libpq connection string or postgres:// URI; several hosts: see
  // above) and runs options.setup after turning synchronous_commit on. Unavailable if no
  // host can be reached (or none is a primary able to commit), with libpq's message (which
  // never includes the password). A DSN libpq cannot parse is InvalidArgument.
  static absl::StatusOr<std::unique_ptr<PgConnection>> Connect(const std::string& dsn,
                                                               const PgOptions& options = {});
  ~PgConnection();
  PgConnection(const PgConnection&) = delete;
  PgConnection& operator=(const PgConnection&) = delete;

  // Runs one statement with `params`; rows (binary) for a query, none otherwise.
  absl::StatusOr<PgResult> Exec(std::string_view sql, const PgParams& params = {});
  // Runs statements without parameters (several separated by ';').
  absl::Status ExecScript(std::string_view sql);
  // True when the connection is usable (not broken by a network error, a deadline, or a
  // server that turned out to be a standby).
  bool healthy() const;
  // Reconnects a broken connection (trying every host of the DSN). Unavailable if none
  // can be reached.
  absl::Status Reset();
  // "host:port" of the server this connection is on ("" while broken).
  std::string server() const;
  // A new connection to the same hosts with the same options, sharing this one's
  // knowledge of which host is primary. Unavailable as Connect.
  absl::StatusOr<std::unique_ptr<PgConnection>> Another() const;

 private:
  struct Hosts;  // the DSN's parsed options and host list (postgres.cc)
  PgConnection(std::shared_ptr<const Hosts> hosts, PgOptions options);
  absl::Status Open();
  absl::StatusOr<pg_conn*> OpenHost(size_t i);  // connected, not checked
  void Install(pg_conn* c);
  // OK for a primary able to commit (see above); Unavailable saying what the server is.
  absl::Status CheckPrimary();
  absl::Status Check(pg_result* r, std::string_view sql);
  // Sends what `send` queued and waits for every result until the deadline; the last.
  absl::StatusOr<PgResult> Await(bool sent, std::string_view sql);
  void Drop();
  absl::Status Setup();

  pg_conn* c_ = nullptr;  // nullptr while broken
  std::shared_ptr<const Hosts> hosts_;
  const PgOptions options_;
  size_t host_ = 0;           // the host c_ is on (several hosts)
  bool failed_here_ = false;  // host_ failed this connection: start the next Open after it
};

class PgPool {
 public:
  // Opens `size` connections to `dsn` (at least 1), each with `options` (Connect).
  // The Connect error otherwise.
  static absl::StatusOr<std::unique_ptr<PgPool>> Open(const std::string& dsn, int size,
                                                      const PgOptions& options = {});

  // A connection taken from the pool; back to it on destruction (a broken one is reset
  // first).
  class Lease {
   public:
    Lease(PgPool* pool, std::unique_ptr<PgConnection> c) : pool_(pool), c_(std::move(c)) {}
    Lease(Lease&&) = default;
    ~Lease();
    PgConnection* operator->() const { return c_.get(); }
    PgConnection& operator*() const { return *c_; }

   private:
    PgPool* pool_;
    std::unique_ptr<PgConnection> c_;
  };
  // Blocks until a connection is free.
  Lease Take();

 private:
  PgPool() = default;
  std::mutex mu_;
  std::condition_variable cv_;
  std::vector<std::unique_ptr<PgConnection>> free_;  // guarded by mu_
};

// BEGIN (with `mode`, e.g. "ISOLATION LEVEL REPEATABLE READ") on construction; ROLLBACK
// on destruction unless Commit() succeeded.
class PgTransaction {
 public:
  explicit PgTransaction(PgConnection& c, std::string_view mode = "");
  ~PgTransaction();
  PgTransaction(const PgTransaction&) = delete;
  PgTransaction& operator=(const PgTransaction&) = delete;

  const absl::Status& status() const { return status_; }
  absl::Status Commit();

 private:
  PgConnection& c_;
  absl::Status status_;
  bool open_ = false;
};

// True for the errors a transaction retried from the start may not meet again
// (serialization failure, deadlock): PgConnection reports them as Unavailable with
// "SQLSTATE 40001" / "40P01" in the message.
bool IsRetryable(const absl::Status& s);
// The number of hosts `dsn` lists (0 when libpq cannot parse it, 1 without a host).
int PgHostCount(const std::string& dsn);

// True when `s` (Unavailable, not IsRetryable) says the connection is gone or on a server
// that cannot write: what a reconnect, perhaps to another host, may cure.
bool IsConnectionLost(const absl::Status& s);

}  // namespace skimap::storage

#endif  // SKIMAP_STORAGE_POSTGRES_H_
