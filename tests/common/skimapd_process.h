// SkimapdProcess: a real skimapd child process on a free loopback port (and its REST API on
// another: http_port()), for tests that must hold against the daemon itself (a crash ends
// the process, not only a call).
//
//   SkimapdProcess server(SKIMAPD_PATH, {"--worker_threads=1"});
//   ASSERT_TRUE(server.Start().ok());
//   auto client = client::MapClient::Connect(server.address());
//   ...
//   EXPECT_TRUE(server.Running());   // still alive after what the test sent
//
// The destructor kills the process (SIGKILL) if the test did not Stop() it.
//
// Thread safety: a test-thread object.
#ifndef TESTS_COMMON_SKIMAPD_PROCESS_H_
#define TESTS_COMMON_SKIMAPD_PROCESS_H_

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "client/map_client.h"
#include "tests/common/free_port.h"
#include "tests/common/spawn.h"

namespace skimap::testing {

class SkimapdProcess {
 public:
  SkimapdProcess(std::string binary, std::vector<std::string> flags)
      : binary_(std::move(binary)), flags_(std::move(flags)) {}
  ~SkimapdProcess() {
    if (pid_ > 0) {
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
    }
    if (!data_dir_.empty()) std::filesystem::remove_all(data_dir_);
  }
  SkimapdProcess(const SkimapdProcess&) = delete;
  SkimapdProcess& operator=(const SkimapdProcess&) = delete;

  // How Start() connects to wait for the server (TLS, token: client/channel.h).
  void set_connection(client::Connection connection) { connection_ = std::move(connection); }
  // Sends the process's stdout and stderr to `path` (appended) instead of the test's.
  void set_log_file(std::string path) { log_file_ = std::move(path); }

  // Forks skimapd on 127.0.0.1:<free port> with a fresh data dir (the same one again after
  // CrashAndRestart) and waits until it accepts calls (Unavailable after 20 s,
  // FailedPrecondition as soon as the process exits).
  absl::Status Start() { return StartOn("127.0.0.1"); }
  // Like Start, listening on `host` (clients still connect through 127.0.0.1).
  absl::Status StartOn(const std::string& host) {
    // FreePort's ports can be taken by another test's process before skimapd binds them
    // (ctest runs tests in parallel); skimapd then exits at start ("cannot listen on"),
    // so a start whose process exits is tried again on fresh ports. A start that fails for
    // another reason fails every attempt the same way.
    constexpr int kAttempts = 3;
    absl::Status s;
    for (int attempt = 0; attempt < kAttempts; ++attempt) {
      s = StartOnce(host);
      if (!absl::IsFailedPrecondition(s)) return s;
    }
    return s;
  }

  // Appends the process's stderr to `path` (from the next Start on) instead of the test's.
  void RedirectStderr(std::string path) { stderr_path_ = std::move(path); }

  // True while the process has not exited.
  bool Running() {
    if (pid_ <= 0) return false;
    int status = 0;
    if (waitpid(pid_, &status, WNOHANG) == 0) return true;
    pid_ = -1;
    return false;
  }

 private:
  // One start on fresh ports; FailedPrecondition when the process exits before serving.
  absl::Status StartOnce(const std::string& host) {
    const int port = FreePort();
    address_ = absl::StrCat("127.0.0.1:", port);
    const std::string listen = absl::StrCat(host, ":", port);
    if (data_dir_.empty()) {
      data_dir_ = (std::filesystem::temp_directory_path() /
                   absl::StrCat("skimapd_test_", getpid(), "_", ++count_))
                      .string();
      std::filesystem::create_directories(data_dir_);
    }
    http_port_ = FreePort();
    std::vector<std::string> args = {binary_, "--address=" + listen,
                                     "--data_dir=" + data_dir_ + "/data",
                                     absl::StrCat("--http_address=127.0.0.1:", http_port_)};
    args.insert(args.end(), flags_.begin(), flags_.end());
    SpawnOptions redirect;
    if (!log_file_.empty()) {
      redirect = {.stdout_path = log_file_, .stderr_path = log_file_};
    } else {
      redirect.stderr_path = stderr_path_;
    }
    pid_ = SpawnProcess(args, redirect);
    if (pid_ < 0) return absl::InternalError(absl::StrCat("cannot start ", binary_));
    // Waits in short steps so a process that refuses to start fails the call at once.
    auto client = client::MapClient::Connect(address_, {.connection = connection_});
    const absl::Time deadline = absl::Now() + absl::Seconds(20);
    for (;;) {
      absl::Status ready = client->WaitForServer(absl::Milliseconds(200));
      if (ready.ok() || absl::Now() >= deadline) return ready;
      if (!Running()) return absl::FailedPreconditionError("skimapd exited at start");
    }
  }

 public:
  // kill -9 (no chance to flush anything), then Start() again on the same data dir.
  absl::Status CrashAndRestart() {
    if (pid_ > 0) {
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
      pid_ = -1;
    }
    return Start();
  }

  // kill -9 without a restart (the data dir stays for Start()).
  void Kill() {
    if (pid_ <= 0) return;
    kill(pid_, SIGKILL);
    waitpid(pid_, nullptr, 0);
    pid_ = -1;
  }
  // Sends `signal` (e.g. SIGSTOP, SIGCONT) to the running process.
  void Signal(int signal) {
    if (pid_ > 0) kill(pid_, signal);
  }

  // SIGTERM, then the exit code (-1 if it died of a signal).
  int Stop() {
    if (pid_ <= 0) return -1;
    kill(pid_, SIGTERM);
    int status = 0;
    waitpid(pid_, &status, 0);
    pid_ = -1;
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }

  // Peak resident memory of the process so far (VmHWM), bytes; 0 if unknown.
  size_t PeakRssBytes() const {
    std::ifstream status(absl::StrCat("/proc/", pid_, "/status"));
    std::string key;
    while (status >> key) {
      if (key == "VmHWM:") {
        size_t kb = 0;
        status >> kb;
        return kb * 1024;
      }
      status.ignore(256, '\n');
    }
    return 0;
  }

  const std::string& address() const { return address_; }
  // The REST port on 127.0.0.1 (unless the flags moved or disabled it with --http_address).
  int http_port() const { return http_port_; }
  // The process id (-1 when not running).
  pid_t pid() const { return pid_; }
  // The --data_dir of the process (maps.sqlite, objects.sqlite); empty before Start.
  std::string data_dir() const { return data_dir_.empty() ? "" : data_dir_ + "/data"; }

 private:
  static inline int count_ = 0;
  const std::string binary_;
  const std::vector<std::string> flags_;
  std::string address_, data_dir_, stderr_path_, log_file_;
  client::Connection connection_;
  pid_t pid_ = -1;
  int http_port_ = 0;
};

}  // namespace skimap::testing

#endif  // TESTS_COMMON_SKIMAPD_PROCESS_H_
