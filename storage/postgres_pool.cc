// postgres.h: PgPool, PgTransaction and the error and DSN helpers.
#include <libpq-fe.h>

#include <algorithm>
#include <cstring>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "storage/postgres.h"

namespace skimap::storage {

absl::StatusOr<std::unique_ptr<PgPool>> PgPool::Open(const std::string& dsn, int size,
                                                     const PgOptions& options) {
  std::unique_ptr<PgPool> pool(new PgPool());
  absl::StatusOr<std::unique_ptr<PgConnection>> first = PgConnection::Connect(dsn, options);
  if (!first.ok()) return first.status();
  pool->free_.push_back(*std::move(first));
  // The others share the first's parsed hosts and its knowledge of the primary.
  for (int i = 1; i < size; ++i) {
    absl::StatusOr<std::unique_ptr<PgConnection>> c = pool->free_.front()->Another();
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

int PgHostCount(const std::string& dsn) {
  PQconninfoOption* parsed = PQconninfoParse(dsn.c_str(), nullptr);
  if (parsed == nullptr) return 0;
  int n = 1;
  for (PQconninfoOption* o = parsed; o->keyword != nullptr; ++o) {
    if (o->val != nullptr && std::string_view(o->keyword) == "host") {
      n = int(std::count(o->val, o->val + std::strlen(o->val), ',')) + 1;
    }
  }
  PQconninfoFree(parsed);
  return n;
}

bool IsConnectionLost(const absl::Status& s) { return absl::IsUnavailable(s) && !IsRetryable(s); }

}  // namespace skimap::storage
