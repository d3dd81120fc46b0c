#include "storage/postgres.h"

#include <libpq-fe.h>

#include <cstring>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"

namespace skimap::storage {
namespace {

// Type OIDs of the parameters (pg_type.h).
constexpr unsigned int kInt8Oid = 20;
constexpr unsigned int kTextOid = 25;
constexpr unsigned int kByteaOid = 17;
constexpr unsigned int kBoolOid = 16;

std::string BigEndian(uint64_t v, int bytes) {
  std::string out(bytes, '\0');
  for (int i = bytes - 1; i >= 0; --i, v >>= 8) out[i] = char(v & 0xff);
  return out;
}

absl::Status FromSqlState(const std::string& state, std::string message) {
  const std::string msg = absl::StrCat(message, " (SQLSTATE ", state, ")");
  if (state == "23505") return absl::AlreadyExistsError(msg);
  if (state == "40001" || state == "40P01") return absl::UnavailableError(msg);
  if (absl::StartsWith(state, "08") || state == "57P01" || state == "57P02" || state == "57P03") {
    return absl::UnavailableError(msg);  // connection exceptions, server shutting down
  }
  if (state == "53100" || state == "53200" || state == "53300") {
    return absl::ResourceExhaustedError(msg);  // disk full, out of memory, connections
  }
  if (absl::StartsWith(state, "22") || absl::StartsWith(state, "23")) {
    return absl::InvalidArgumentError(msg);  // data exception, integrity constraint
  }
  return absl::InternalError(msg);
}

}  // namespace

PgParams& PgParams::Int(int64_t v) {
  values_.push_back(BigEndian(uint64_t(v), 8));
  types_.push_back(kInt8Oid);
  return *this;
}
PgParams& PgParams::Text(std::string_view v) {
  values_.emplace_back(v);
  types_.push_back(kTextOid);
  return *this;
}
PgParams& PgParams::Bytes(std::string_view v) {
  values_.emplace_back(v);
  types_.push_back(kByteaOid);
  return *this;
}
PgParams& PgParams::Bool(bool v) {
  values_.emplace_back(1, v ? '\1' : '\0');
  types_.push_back(kBoolOid);
  return *this;
}

PgResult& PgResult::operator=(PgResult&& o) noexcept {
  if (this != &o) {
    if (r_ != nullptr) PQclear(r_);
    r_ = o.r_;
    o.r_ = nullptr;
  }
  return *this;
}
PgResult::~PgResult() {
  if (r_ != nullptr) PQclear(r_);
}
int PgResult::rows() const { return PQntuples(r_); }
int64_t PgResult::affected() const {
  const char* n = PQcmdTuples(r_);
  return (n == nullptr || *n == '\0') ? 0 : std::strtoll(n, nullptr, 10);
}
bool PgResult::IsNull(int row, int col) const { return PQgetisnull(r_, row, col) != 0; }
int64_t PgResult::Int(int row, int col) const {
  const auto* p = reinterpret_cast<const unsigned char*>(PQgetvalue(r_, row, col));
  const int n = PQgetlength(r_, row, col);  // 8 (int8), 4 (int4) or 2 (int2)
  uint64_t v = 0;
  for (int i = 0; i < n; ++i) v = v << 8 | p[i];
  if (n < 8 && n > 0 && (p[0] & 0x80)) v |= ~uint64_t{0} << (8 * n);  // sign-extend
  return int64_t(v);
}
bool PgResult::Bool(int row, int col) const { return PQgetvalue(r_, row, col)[0] != 0; }
std::string PgResult::tag() const { return PQcmdStatus(r_); }
std::string PgResult::Bytes(int row, int col) const {
  return std::string(PQgetvalue(r_, row, col), PQgetlength(r_, row, col));
}

absl::StatusOr<std::unique_ptr<PgConnection>> PgConnection::Connect(const std::string& dsn,
                                                                    const std::string& setup) {
  pg_conn* c = PQconnectdb(dsn.c_str());
  if (c == nullptr) return absl::ResourceExhaustedError("postgres: out of memory");
  if (PQstatus(c) != CONNECTION_OK) {
    absl::Status s =
        absl::UnavailableError(absl::StrCat("postgres: cannot connect: ", PQerrorMessage(c)));
    PQfinish(c);
    return s;
  }
  auto conn = std::unique_ptr<PgConnection>(new PgConnection(c, setup));
  if (absl::Status s = conn->Setup(); !s.ok()) return s;
  return conn;
}

absl::Status PgConnection::Setup() {
  // Durable commits whatever the server's default: an acknowledged frame is on disk.
  absl::Status s = ExecScript("SET synchronous_commit = on; SET client_min_messages = warning");
  if (!s.ok() || setup_.empty()) return s;
  return ExecScript(setup_);
}

PgConnection::~PgConnection() { PQfinish(c_); }

bool PgConnection::healthy() const { return PQstatus(c_) == CONNECTION_OK; }

absl::Status PgConnection::Reset() {
  PQreset(c_);
  if (!healthy()) {
    return absl::UnavailableError(absl::StrCat("postgres: reconnect failed: ", PQerrorMessage(c_)));
  }
  return Setup();
}

absl::Status PgConnection::Check(pg_result* r, std::string_view sql) const {
  const ExecStatusType st = r == nullptr ? PGRES_FATAL_ERROR : PQresultStatus(r);
  if (st == PGRES_COMMAND_OK || st == PGRES_TUPLES_OK) return absl::OkStatus();
  const char* state = r == nullptr ? nullptr : PQresultErrorField(r, PG_DIAG_SQLSTATE);
  std::string message = absl::StrCat("postgres: ", PQerrorMessage(c_));
  while (!message.empty() && message.back() == '\n') message.pop_back();
  if (state == nullptr) return absl::UnavailableError(message);  // no answer: connection lost
  return FromSqlState(state, std::move(message));
}

absl::StatusOr<PgResult> PgConnection::Exec(std::string_view sql, const PgParams& params) {
  const std::string query(sql);
  std::vector<const char*> values;
  std::vector<int> lengths, formats;
  for (const std::string& v : params.values_) {
    values.push_back(v.data());
    lengths.push_back(int(v.size()));
    formats.push_back(1);
  }
  PgResult r(PQexecParams(c_, query.c_str(), int(values.size()), params.types_.data(),
                          values.data(), lengths.data(), formats.data(), /*resultFormat=*/1));
  if (absl::Status s = Check(r.r_, sql); !s.ok()) return s;
  return r;
}

absl::Status PgConnection::ExecScript(std::string_view sql) {
  PgResult r(PQexec(c_, std::string(sql).c_str()));
  return Check(r.r_, sql);
}

absl::StatusOr<std::unique_ptr<PgPool>> PgPool::Open(const std::string& dsn, int size,
                                                     const std::string& setup) {
  std::unique_ptr<PgPool> pool(new PgPool());
  for (int i = 0; i < std::max(1, size); ++i) {
    absl::StatusOr<std::unique_ptr<PgConnection>> c = PgConnection::Connect(dsn, setup);
    if (!c.ok()) return c.status();
    pool->free_.push_back(*std::move(c));
  }
  return pool;
}

PgPool::Lease PgPool::Take() {
  std::unique_lock<std::mutex> lock(mu_);
  cv_.wait(lock, [this] { return !free_.empty(); });
  std::unique_ptr<PgConnection> c = std::move(free_.back());
  free_.pop_back();
  return Lease(this, std::move(c));
}

PgPool::Lease::~Lease() {
  if (c_ == nullptr) return;
  if (!c_->healthy()) (void)c_->Reset();  // a failed reset retries on the next use
  {
    std::lock_guard<std::mutex> lock(pool_->mu_);
    pool_->free_.push_back(std::move(c_));
  }
  pool_->cv_.notify_one();
}

PgTransaction::PgTransaction(PgConnection& c, std::string_view mode) : c_(c) {
  if (!c_.healthy()) status_ = c_.Reset();
  if (status_.ok()) status_ = c_.ExecScript(absl::StrCat("BEGIN ", std::string(mode)));
  open_ = status_.ok();
}

PgTransaction::~PgTransaction() {
  if (open_) (void)c_.ExecScript("ROLLBACK");
}

absl::Status PgTransaction::Commit() {
  open_ = false;  // COMMIT ends the transaction whatever it answers
  absl::StatusOr<PgResult> r = c_.Exec("COMMIT");
  if (!r.ok()) return r.status();
  // COMMIT of a transaction that met an error rolls it back and says so.
  if (r->tag() != "COMMIT") return absl::AbortedError("postgres: transaction rolled back");
  return absl::OkStatus();
}

bool IsRetryable(const absl::Status& s) {
  return absl::IsUnavailable(s) && (absl::StrContains(s.message(), "SQLSTATE 40001") ||
                                    absl::StrContains(s.message(), "SQLSTATE 40P01"));
}

}  // namespace skimap::storage
