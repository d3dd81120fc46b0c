#include "storage/postgres.h"

#include <libpq-fe.h>
#include <poll.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstring>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"

namespace skimap::storage {
namespace {

absl::Status FromSqlState(const std::string& state, std::string message) {
  const std::string msg = absl::StrCat(message, " (SQLSTATE ", state, ")");
  if (state == "23505") return absl::AlreadyExistsError(msg);
  if (state == "40001" || state == "40P01") return absl::UnavailableError(msg);
  // lock_not_available: a lock wait past lock_timeout (a session of ours the client dropped
  // may still hold the lock until the server notices): retry.
  if (state == "55P03") return absl::UnavailableError(msg);
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

// The DSN as libpq parsed it: every option it sets, with its hosts and ports split.
struct PgConnection::Hosts {
  std::string dsn;
  std::vector<std::string> keywords, values;  // options other than host / port
  std::vector<std::string> hosts, ports;      // ports: one per host
  // The host a connection last found a primary on; where the others start.
  mutable std::atomic<size_t> primary_hint{0};
  bool several() const { return hosts.size() > 1; }
};

PgConnection::PgConnection(std::shared_ptr<const Hosts> hosts, PgOptions options)
    : hosts_(std::move(hosts)), options_(std::move(options)) {}

absl::StatusOr<std::unique_ptr<PgConnection>> PgConnection::Connect(const std::string& dsn,
                                                                    const PgOptions& options) {
  auto hosts = std::make_shared<Hosts>();
  hosts->dsn = dsn;
  char* error = nullptr;
  PQconninfoOption* parsed = PQconninfoParse(dsn.c_str(), &error);
  if (parsed == nullptr) {
    // libpq's message quotes the part it could not read, which may be the password.
    PQfreemem(error);
    return absl::InvalidArgumentError(
        "postgres: the connection string cannot be parsed (a libpq URI "
        "postgresql://user@host:port,host:port/db?param=value or key=value pairs)");
  }
  bool hostaddr = false;
  for (PQconninfoOption* o = parsed; o->keyword != nullptr; ++o) {
    if (o->val == nullptr) continue;
    const std::string keyword = o->keyword;
    if (keyword == "host") {
      hosts->hosts = absl::StrSplit(o->val, ',');
    } else if (keyword == "port") {
      hosts->ports = absl::StrSplit(o->val, ',');
    } else {
      hostaddr |= keyword == "hostaddr";
      hosts->keywords.push_back(keyword);
      hosts->values.push_back(o->val);
    }
  }
  PQconninfoFree(parsed);
  if (hostaddr || hosts->hosts.size() < 2) {
    hosts->hosts.clear();  // one server: libpq reads the DSN as it is
  } else {
    if (hosts->ports.size() > 1 && hosts->ports.size() != hosts->hosts.size()) {
      return absl::InvalidArgumentError(
          absl::StrCat("postgres: connection string: ", hosts->hosts.size(), " hosts but ",
                       hosts->ports.size(), " ports"));
    }
    if (hosts->ports.size() <= 1)
      hosts->ports.resize(hosts->hosts.size(), hosts->ports.empty() ? "" : hosts->ports[0]);
    if (std::find(hosts->keywords.begin(), hosts->keywords.end(), "connect_timeout") ==
        hosts->keywords.end()) {
      hosts->keywords.push_back("connect_timeout");  // a host that is down costs 2 s, not 2 min
      hosts->values.push_back("2");
    }
  }
  auto conn = std::unique_ptr<PgConnection>(new PgConnection(std::move(hosts), options));
  if (absl::Status s = conn->Open(); !s.ok()) return s;
  return conn;
}

absl::StatusOr<pg_conn*> PgConnection::OpenHost(size_t i) {
  std::vector<const char*> keys, values;
  for (size_t k = 0; k < hosts_->keywords.size(); ++k) {
    keys.push_back(hosts_->keywords[k].c_str());
    values.push_back(hosts_->values[k].c_str());
  }
  keys.push_back("host");
  values.push_back(hosts_->hosts[i].c_str());
  if (!hosts_->ports[i].empty()) {
    keys.push_back("port");
    values.push_back(hosts_->ports[i].c_str());
  }
  keys.push_back(nullptr);
  values.push_back(nullptr);
  pg_conn* c = PQconnectdbParams(keys.data(), values.data(), /*expand_dbname=*/0);
  if (c == nullptr) return absl::ResourceExhaustedError("postgres: out of memory");
  if (PQstatus(c) == CONNECTION_OK) return c;
  std::string why = PQerrorMessage(c);
  PQfinish(c);
  while (!why.empty() && why.back() == '\n') why.pop_back();
  return absl::UnavailableError(why);
}

void PgConnection::Install(pg_conn* c) {
  c_ = c;
  // Non-blocking: a server that stops reading cannot hold a send past the deadline.
  PQsetnonblocking(c_, 1);
  // The server's notices (and the FATAL it sends to an idle connection as it shuts down)
  // would go to stderr, around skimapd's log; errors reach callers as statuses.
  PQsetNoticeProcessor(
      c_, [](void*, const char*) {}, nullptr);
}

absl::Status PgConnection::CheckPrimary() {
  // A primary able to commit: not in recovery, and synchronous replication either off or
  // with a synchronous standby streaming (a row whose state this role may not read
  // counts: it cannot tell, and the commit's own wait decides).
  absl::StatusOr<PgResult> r = Exec(
      "SELECT pg_is_in_recovery(), current_setting('synchronous_standby_names') <> '', "
      "(SELECT count(*) FROM pg_stat_replication WHERE sync_state IN ('sync', 'quorum') OR "
      "sync_state IS NULL)");
  if (!r.ok()) return r.status();
  if (r->Bool(0, 0)) return absl::UnavailableError("a standby (in recovery)");
  if (r->Bool(0, 1) && r->Int(0, 2) == 0) {
    return absl::UnavailableError(
        "a primary configured for synchronous replication without a synchronous standby (cut "
        "off from its cluster: its commits would wait)");
  }
  return absl::OkStatus();
}

absl::Status PgConnection::Open() {
  Drop();
  if (!hosts_->several()) {
    // The DSN as it is, with a connect timeout unless it sets one (a server that stopped
    // answering would hold the connect forever).
    const bool timeout_set = std::find(hosts_->keywords.begin(), hosts_->keywords.end(),
                                       "connect_timeout") != hosts_->keywords.end();
    const char* keys[] = {"dbname", timeout_set ? nullptr : "connect_timeout", nullptr};
    const char* values[] = {hosts_->dsn.c_str(), "10", nullptr};
    pg_conn* c = PQconnectdbParams(keys, values, /*expand_dbname=*/1);
    if (c == nullptr) return absl::ResourceExhaustedError("postgres: out of memory");
    if (PQstatus(c) != CONNECTION_OK) {
      absl::Status s =
          absl::UnavailableError(absl::StrCat("postgres: cannot connect: ", PQerrorMessage(c)));
      PQfinish(c);
      return s;
    }
    Install(c);
  } else {
    // From the last known primary, or from the next host when that is where this
    // connection just failed.
    const size_t n = hosts_->hosts.size();
    size_t first = hosts_->primary_hint.load() % n;
    if (first == host_ && failed_here_) first = (first + 1) % n;
    std::vector<std::string> why;
    for (size_t k = 0; k < n && c_ == nullptr; ++k) {
      const size_t i = (first + k) % n;
      absl::StatusOr<pg_conn*> c = OpenHost(i);
      absl::Status s = c.status();
      if (c.ok()) {
        Install(*c);
        s = CheckPrimary();  // with the statement deadline
        if (!s.ok()) Drop();
      }
      if (!s.ok()) {
        why.push_back(absl::StrCat(hosts_->hosts[i], ":", hosts_->ports[i], ": ", s.message()));
        continue;
      }
      host_ = i;
      hosts_->primary_hint.store(i);
    }
    if (c_ == nullptr) {
      return absl::UnavailableError(
          absl::StrCat("postgres: no primary among the hosts: ", absl::StrJoin(why, "; ")));
    }
  }
  failed_here_ = false;
  if (absl::Status s = Setup(); !s.ok()) {
    Drop();  // not used without synchronous_commit and the caller's settings
    return s;
  }
  return absl::OkStatus();
}

absl::Status PgConnection::Setup() {
  // Durable commits whatever the server's default: an acknowledged frame is on disk. A lock
  // wait ends before the client's deadline, and the server checks for a vanished client
  // once a second: a session this client dropped cannot hold row locks for long.
  const int64_t lock_ms =
      std::max<int64_t>(500, absl::ToInt64Milliseconds(options_.statement_timeout) - 500);
  absl::Status s = ExecScript(absl::StrCat(
      "SET synchronous_commit = on; SET client_min_messages = warning; SET lock_timeout = ",
      lock_ms, "; SET client_connection_check_interval = 1000"));
  if (!s.ok() || options_.setup.empty()) return s;
  return ExecScript(options_.setup);
}

absl::StatusOr<std::unique_ptr<PgConnection>> PgConnection::Another() const {
  auto conn = std::unique_ptr<PgConnection>(new PgConnection(hosts_, options_));
  if (absl::Status s = conn->Open(); !s.ok()) return s;
  return conn;
}

PgConnection::~PgConnection() { Drop(); }

void PgConnection::Drop() {
  if (c_ == nullptr) return;
  PQfinish(c_);
  c_ = nullptr;
  failed_here_ = true;
}

bool PgConnection::healthy() const { return c_ != nullptr && PQstatus(c_) == CONNECTION_OK; }

std::string PgConnection::server() const {
  if (c_ == nullptr) return "";
  return absl::StrCat(PQhost(c_), ":", PQport(c_));
}

absl::Status PgConnection::Reset() {
  if (c_ != nullptr) failed_here_ = true;
  absl::Status s = Open();
  if (!s.ok()) {
    return absl::UnavailableError(absl::StrCat("postgres: reconnect failed: ", s.message()));
  }
  if (options_.reconnects != nullptr) ++*options_.reconnects;
  return s;
}

absl::Status PgConnection::Check(pg_result* r, std::string_view sql) {
  const ExecStatusType st = r == nullptr ? PGRES_FATAL_ERROR : PQresultStatus(r);
  if (st == PGRES_COMMAND_OK || st == PGRES_TUPLES_OK) return absl::OkStatus();
  const char* state = r == nullptr ? nullptr : PQresultErrorField(r, PG_DIAG_SQLSTATE);
  std::string message = absl::StrCat("postgres: ", c_ != nullptr ? PQerrorMessage(c_) : "");
  while (!message.empty() && message.back() == '\n') message.pop_back();
  if (state == nullptr) {  // no answer: connection lost
    Drop();
    return absl::UnavailableError(message);
  }
  if (std::string_view(state) == "25006") {
    // A read-only server (a primary demoted under us): the next host may be the primary.
    Drop();
    return absl::UnavailableError(absl::StrCat(message, " (SQLSTATE 25006)"));
  }
  return FromSqlState(state, std::move(message));
}

absl::StatusOr<PgResult> PgConnection::Await(bool sent, std::string_view sql) {
  if (!sent) return Check(nullptr, sql);
  const absl::Time deadline = absl::Now() + options_.statement_timeout;
  const int fd = PQsocket(c_);
  // Waits for the socket (POLLIN, plus POLLOUT while unsent data remains); false past the
  // deadline.
  auto wait = [&](bool writing) {
    pollfd p{fd, short(POLLIN | (writing ? POLLOUT : 0)), 0};
    for (;;) {
      const int64_t ms = absl::ToInt64Milliseconds(deadline - absl::Now());
      if (ms <= 0) return false;
      const int n = poll(&p, 1, int(std::min<int64_t>(ms, 1000)));
      if (n > 0 || (n < 0 && errno != EINTR)) return true;
    }
  };
  auto timed_out = [&] {
    Drop();
    return absl::UnavailableError(absl::StrCat(
        "postgres: no answer within ", absl::FormatDuration(options_.statement_timeout),
        " (the server stopped answering); connection dropped"));
  };
  for (;;) {
    const int f = PQflush(c_);
    if (f < 0) return Check(nullptr, sql);
    if (f == 0) break;
    if (!wait(true)) return timed_out();
    if (!PQconsumeInput(c_)) return Check(nullptr, sql);
  }
  PgResult kept(nullptr);  // the first error, or else the last result
  for (;;) {
    while (PQisBusy(c_)) {
      if (!wait(false)) return timed_out();
      if (!PQconsumeInput(c_)) return Check(nullptr, sql);  // connection lost
    }
    pg_result* r = PQgetResult(c_);
    if (r == nullptr) break;
    const bool kept_error = kept.r_ != nullptr && PQresultStatus(kept.r_) != PGRES_COMMAND_OK &&
                            PQresultStatus(kept.r_) != PGRES_TUPLES_OK;
    if (kept_error) {
      PQclear(r);
    } else {
      kept = PgResult(r);
    }
    if (PQstatus(c_) == CONNECTION_BAD && !PQisBusy(c_)) {
      // Nothing more will come; drain what libpq still holds.
      while ((r = PQgetResult(c_)) != nullptr) PQclear(r);
      break;
    }
  }
  if (absl::Status s = Check(kept.r_, sql); !s.ok()) return s;
  return kept;
}

absl::StatusOr<PgResult> PgConnection::Exec(std::string_view sql, const PgParams& params) {
  if (c_ == nullptr) return absl::UnavailableError("postgres: not connected");
  const std::string query(sql);
  std::vector<const char*> values;
  std::vector<int> lengths, formats;
  for (const std::string& v : params.values_) {
    values.push_back(v.data());
    lengths.push_back(int(v.size()));
    formats.push_back(1);
  }
  return Await(PQsendQueryParams(c_, query.c_str(), int(values.size()), params.types_.data(),
                                 values.data(), lengths.data(), formats.data(),
                                 /*resultFormat=*/1) == 1,
               sql);
}

absl::Status PgConnection::ExecScript(std::string_view sql) {
  if (c_ == nullptr) return absl::UnavailableError("postgres: not connected");
  return Await(PQsendQuery(c_, std::string(sql).c_str()) == 1, sql).status();
}

}  // namespace skimap::storage
