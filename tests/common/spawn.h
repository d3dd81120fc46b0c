// Starting a child process from a test that has threads running (gRPC's, streams').
//
// fork() copies only the calling thread: a lock another thread held at that moment (the
// allocator's, ASan's) stays held forever in the child, so a child that allocates before
// exec can hang. SpawnProcess therefore uses posix_spawn only (glibc's does not allocate
// in the child): every string and the redirections are prepared in the parent.
//
//   pid_t pid = SpawnProcess({SKIMAPD_PATH, "--address=127.0.0.1:5000"});
//
// Thread safety: pure functions; a KillOnExit belongs to one thread.
#ifndef TESTS_COMMON_SPAWN_H_
#define TESTS_COMMON_SPAWN_H_

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/types.h>
#include <sys/wait.h>

#include <string>
#include <vector>

extern char** environ;

namespace skimap::testing {

struct SpawnOptions {
  std::string stdout_path;  // appended to (created 0600); "" = inherited
  std::string stderr_path;  // appended to (created 0600); "" = inherited; may equal stdout_path
};

// Starts args[0] (a path, PATH is not searched) with argv `args` and this environment.
// The child's pid, or -1 when it could not be started.
inline pid_t SpawnProcess(const std::vector<std::string>& args, const SpawnOptions& options = {}) {
  std::vector<char*> argv;
  for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  constexpr int kFlags = O_WRONLY | O_CREAT | O_APPEND;
  if (!options.stdout_path.empty()) {
    posix_spawn_file_actions_addopen(&actions, 1, options.stdout_path.c_str(), kFlags, 0600);
  }
  if (!options.stderr_path.empty()) {
    if (options.stderr_path == options.stdout_path) {
      posix_spawn_file_actions_adddup2(&actions, 1, 2);
    } else {
      posix_spawn_file_actions_addopen(&actions, 2, options.stderr_path.c_str(), kFlags, 0600);
    }
  }
  pid_t pid = -1;
  const int error = posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  return error == 0 ? pid : -1;
}

// SIGKILL and reap `pid` if it is still a child of ours (pid <= 0: nothing).
inline void KillAndReap(pid_t pid) {
  if (pid > 0 && kill(pid, SIGKILL) == 0) waitpid(pid, nullptr, 0);
}

// A failed assertion returns early: a child must not outlive the test (an orphan that holds
// the test's output pipe keeps ctest waiting until its timeout). Kills and reaps *pid on
// scope exit unless the test set it to 0 after reaping the child itself.
//
//   pid_t pid = SpawnProcess({...});
//   const KillOnExit reaper{&pid};
//   ...; waitpid(pid, &status, 0); pid = 0;
struct KillOnExit {
  pid_t* pid;
  ~KillOnExit() { KillAndReap(*pid); }
};

}  // namespace skimap::testing

#endif  // TESTS_COMMON_SPAWN_H_
