// PgCluster: a replicated PostgreSQL with automatic failover for tests and benchmarks, run by
// scripts/pg_cluster.sh (Debian's pg_auto_failover: a monitor, a primary and one or two
// synchronous standbys on free loopback ports, under a fresh temp dir, torn down with the
// object).
//
//   PgCluster cluster(2);
//   ASSERT_TRUE(cluster.Start().ok());
//   SkimapdProcess node(SKIMAPD_PATH, {"--store=" + cluster.uri()});
//   int p = *cluster.Primary();
//   cluster.Kill(p);                 // kill -9 of its keeper and postgres
//   cluster.WaitForPrimaryOtherThan(p, absl::Seconds(60));
//   cluster.StartNode(p);            // rejoins as a standby
//
// Thread safety: a test-thread object; uri() and the node calls may run on any one thread
// at a time.
#ifndef TESTS_COMMON_PG_CLUSTER_H_
#define TESTS_COMMON_PG_CLUSTER_H_

#include <stdlib.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/ascii.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "tests/common/free_port.h"

#ifndef SKIMAP_PG_CLUSTER_SCRIPT
#error "define SKIMAP_PG_CLUSTER_SCRIPT (scripts/pg_cluster.sh)"
#endif

namespace skimap::testing {

class PgCluster {
 public:
  explicit PgCluster(int data_nodes = 2) : data_nodes_(data_nodes) {}
  ~PgCluster() {
    if (!dir_.empty()) (void)Run("down");
  }
  PgCluster(const PgCluster&) = delete;
  PgCluster& operator=(const PgCluster&) = delete;

  // Starts the monitor and the data nodes and waits for a primary with its standbys.
  absl::Status Start() {
    char tmpl[] = "/tmp/skimap_pgc_XXXXXX";
    if (mkdtemp(tmpl) == nullptr) return absl::InternalError("mkdtemp failed");
    dir_ = tmpl;
    std::string ports;
    for (int i = 0; i <= data_nodes_; ++i) {
      ports_.push_back(FreePort());
      absl::StrAppend(&ports, " ", ports_.back());
    }
    absl::StatusOr<std::string> uri = Run(absl::StrCat("up", ports));
    if (!uri.ok()) return uri.status();
    const std::string out(absl::StripAsciiWhitespace(*uri));
    uri_ = out.substr(out.rfind('\n') + 1);  // the last line
    return absl::OkStatus();
  }

  // skimapd's --store: every data node, target_session_attrs=read-write.
  const std::string& uri() const { return uri_; }
  // A URI of data node n (1-based) alone.
  std::string NodeUri(int n) const {
    return absl::StrCat("postgresql://postgres@127.0.0.1:", ports_[n], "/skimap?connect_timeout=2");
  }
  std::string dir() const { return dir_; }

  // The node the monitor sees as primary (1-based).
  absl::StatusOr<int> Primary() {
    absl::StatusOr<std::string> out = Run("primary");
    if (!out.ok()) return out.status();
    int n = 0;
    if (!absl::SimpleAtoi(absl::StripAsciiWhitespace(*out), &n)) {
      return absl::UnavailableError("no primary now");
    }
    return n;
  }
  // Polls until the monitor names a primary other than `old`.
  absl::StatusOr<int> WaitForPrimaryOtherThan(int old, absl::Duration timeout) {
    const absl::Time deadline = absl::Now() + timeout;
    for (;;) {
      absl::StatusOr<int> p = Primary();
      if (p.ok() && *p != old) return p;
      if (absl::Now() > deadline) return absl::DeadlineExceededError("no new primary");
      absl::SleepFor(absl::Milliseconds(100));
    }
  }
  absl::Status Kill(int n) { return Run(absl::StrCat("kill ", n)).status(); }
  absl::Status StartNode(int n) { return Run(absl::StrCat("start ", n)).status(); }
  absl::Status Pause(int n) { return Run(absl::StrCat("pause ", n)).status(); }
  absl::Status Resume(int n) { return Run(absl::StrCat("resume ", n)).status(); }
  // Until one primary and every other node a secondary.
  absl::Status WaitHealthy(absl::Duration timeout) {
    return Run(absl::StrCat("wait ", absl::ToInt64Seconds(timeout))).status();
  }
  // psql -Atc `sql` on data node n; its output. Unavailable when psql fails or is still
  // waiting after `timeout` (then killed).
  absl::StatusOr<std::string> Psql(int n, const std::string& sql,
                                   absl::Duration timeout = absl::Seconds(60)) {
    return Shell(absl::StrCat("timeout --signal=KILL ", absl::ToInt64Seconds(timeout), " psql -q '",
                              NodeUri(n), "' -v ON_ERROR_STOP=1 -Atc \"", sql, "\""));
  }

 private:
  // scripts/pg_cluster.sh COMMAND DIR ARGS... for args "COMMAND ARGS...".
  absl::StatusOr<std::string> Run(const std::string& args) {
    const size_t space = args.find(' ');
    return Shell(absl::StrCat("bash ", SKIMAP_PG_CLUSTER_SCRIPT, " ", args.substr(0, space), " ",
                              dir_, space == std::string::npos ? "" : args.substr(space)));
  }
  static absl::StatusOr<std::string> Shell(const std::string& command) {
    std::string out;
    FILE* p = popen(absl::StrCat(command, " 2>&1").c_str(), "r");
    if (p == nullptr) return absl::InternalError("popen failed");
    char buf[4096];
    for (size_t n; (n = fread(buf, 1, sizeof buf, p)) > 0;) out.append(buf, n);
    const int rc = pclose(p);
    if (rc != 0) return absl::UnavailableError(absl::StrCat(command, " failed: ", out));
    return out;
  }

  const int data_nodes_;
  std::string dir_, uri_;
  std::vector<int> ports_;  // monitor, node 1, node 2 ...
};

}  // namespace skimap::testing

#endif  // TESTS_COMMON_PG_CLUSTER_H_
