// PostgresServer: a throwaway PostgreSQL server for tests and benchmarks, from Debian's
// postgresql package: initdb into a fresh temp dir, pg_ctl start on a free loopback port
// (Unix socket in the same dir), fsync on, destroyed (immediate stop + rm -rf) with the
// object. Runs the server as the `postgres` system user when this process is root (the
// server refuses root), as this user otherwise.
//
//   PostgresServer pg;
//   ASSERT_TRUE(pg.Start().ok());
//   auto store = storage::PostgresMapStore::Open(pg.Dsn("db1"), {});
//
// Thread safety: a test-thread object; Dsn may be called from any thread after Start.
#ifndef TESTS_COMMON_POSTGRES_SERVER_H_
#define TESTS_COMMON_POSTGRES_SERVER_H_

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "tests/common/free_port.h"

namespace skimap::testing {

class PostgresServer {
 public:
  PostgresServer() = default;
  ~PostgresServer() {
    if (started_) Ctl("-m immediate stop");
    if (!dir_.empty()) std::filesystem::remove_all(dir_);
  }
  PostgresServer(const PostgresServer&) = delete;
  PostgresServer& operator=(const PostgresServer&) = delete;

  // initdb + start; Unavailable (with the log's path) if the server does not come up.
  absl::Status Start() {
    const std::string bin = Bin();
    if (bin.empty()) {
      return absl::FailedPreconditionError(
          "no PostgreSQL server binaries (apt-get install postgresql; scripts/deps.sh)");
    }
    char tmpl[] = "/tmp/skimap_pg_XXXXXX";
    if (mkdtemp(tmpl) == nullptr) return absl::InternalError("mkdtemp failed");
    dir_ = tmpl;
    port_ = FreePort();
    if (getuid() == 0) {
      as_ = "runuser -u postgres -- ";
      if (Run(absl::StrCat("chown postgres ", dir_)) != 0) {
        return absl::FailedPreconditionError("no `postgres` user to run the server as");
      }
    }
    if (Run(absl::StrCat(as_, bin, "/initdb -D ", dir_, "/data -A trust -U skimap -E UTF8 ",
                         "--locale=C --no-sync >", dir_, "/initdb.log 2>&1")) != 0) {
      return absl::UnavailableError(absl::StrCat("initdb failed, see ", dir_, "/initdb.log"));
    }
    started_ = Ctl(absl::StrCat("-w -t 60 -l ", dir_, "/server.log -o \"-k ", dir_,
                                " -c listen_addresses=127.0.0.1 -p ", port_,
                                " -c fsync=on -c synchronous_commit=on -c max_connections=200\" "
                                "start")) == 0;
    if (!started_) {
      return absl::UnavailableError(absl::StrCat("pg_ctl start failed, see ", dir_, "/server.log"));
    }
    return absl::OkStatus();
  }

  // A libpq URI for database `db`, created on first use.
  std::string Dsn(const std::string& db = "postgres") {
    if (db != "postgres") {
      Run(absl::StrCat("psql -q \"", Uri("postgres"), "\" -c 'CREATE DATABASE ", db,
                       "' >/dev/null 2>&1"));
    }
    return Uri(db);
  }
  int port() const { return port_; }
  // The cluster's directory (postmaster.pid holds the server's pid on its first line).
  std::string data_dir() const { return dir_ + "/data"; }
  // pg_ctl with `args` (e.g. "-m fast stop"); its exit code.
  int Ctl(const std::string& args) {
    return Run(absl::StrCat(as_, Bin(), "/pg_ctl -D ", dir_, "/data ", args, " >>", dir_,
                            "/pg_ctl.log 2>&1"));
  }

 private:
  static int Run(const std::string& command) { return std::system(command.c_str()); }
  // The newest installed server's bin directory ("" if none).
  static std::string Bin() {
    for (int v = 20; v >= 12; --v) {
      const std::string dir = absl::StrCat("/usr/lib/postgresql/", v, "/bin");
      if (std::filesystem::exists(dir + "/pg_ctl")) return dir;
    }
    return "";
  }
  std::string Uri(const std::string& db) const {
    return absl::StrCat("postgresql://skimap@127.0.0.1:", port_, "/", db);
  }

  std::string dir_, as_;
  int port_ = 0;
  bool started_ = false;
};

}  // namespace skimap::testing

#endif  // TESTS_COMMON_POSTGRES_SERVER_H_
