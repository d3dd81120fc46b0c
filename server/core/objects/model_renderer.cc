// skimap-model-views as a child process. See model_renderer.h for the contract.
#include "server/core/objects/model_renderer.h"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <fstream>
#include <sstream>
#include <thread>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "base/echo.h"

extern char** environ;

namespace skimap::server {
namespace {

// The renderer's last line of output (its error), at most 300 characters.
std::string LastLine(const std::string& log) {
  std::ifstream in(log);
  std::string line, last;
  while (std::getline(in, line)) {
    if (!line.empty()) last = line;
  }
  return last.substr(0, 300);
}

}  // namespace

absl::Status CheckModelViews(const v1::ModelViews& v) {
  if (!v.units().empty() && v.units() != "auto" && v.units() != "m" && v.units() != "mm") {
    return absl::InvalidArgumentError(
        absl::StrCat("views.units: ", Echo(v.units()), " is not auto, m or mm"));
  }
  if (v.azimuths() > 360) return absl::InvalidArgumentError("views.azimuths: 1..360");
  if (v.distances_size() > 16) return absl::InvalidArgumentError("views.distances: at most 16");
  for (float d : v.distances()) {
    if (!(d >= 0.05f && d <= 100.f)) {
      return absl::InvalidArgumentError("views.distances: each 0.05-100 metres");
    }
  }
  // The renderer parses the list (sim::ParseViewEffects); checked here too, so that the
  // stream is refused before any upload.
  for (absl::string_view e : absl::StrSplit(v.effects(), ',', absl::SkipWhitespace())) {
    if (e != "clutter" && e != "lighting" && e != "sensor" && e != "none") {
      return absl::InvalidArgumentError(absl::StrCat("views.effects: ", Echo(std::string(e)),
                                                     " is not clutter, lighting, sensor or none"));
    }
  }
  if (v.has_intrinsics()) {
    const v1::CameraIntrinsics& k = v.intrinsics();
    if (!(k.fx() > 0 && k.fy() > 0 && k.width() >= 16 && k.width() <= 4096 && k.height() >= 16 &&
          k.height() <= 4096 && std::isfinite(k.cx()) && std::isfinite(k.cy()))) {
      return absl::InvalidArgumentError(
          "views.intrinsics: fx, fy > 0, width and height 16..4096, cx and cy finite");
    }
  }
  return absl::OkStatus();
}

absl::Status RenderModelViews(const ModelRendererOptions& options, const std::string& dir,
                              const std::string& model, const v1::ModelViews& views, int obj_id,
                              const std::string& out) {
  std::vector<std::string> args = {options.binary,
                                   "--model",
                                   model,
                                   "--out",
                                   out,
                                   "--obj_id",
                                   std::to_string(obj_id),
                                   "--max_memory_mb",
                                   std::to_string(options.max_memory_mb),
                                   "--max_cpu_seconds",
                                   std::to_string(options.timeout_seconds)};
  auto add = [&](const char* flag, const std::string& value) {
    args.push_back(flag);
    args.push_back(value);
  };
  if (!views.units().empty()) add("--units", views.units());
  if (views.azimuths() > 0) add("--azimuths", std::to_string(views.azimuths()));
  if (!views.effects().empty()) add("--effects", views.effects());
  if (views.distances_size() > 0) {
    add("--distances", absl::StrJoin(views.distances(), ","));
  }
  if (views.has_intrinsics()) {
    const v1::CameraIntrinsics& k = views.intrinsics();
    add("--camera", absl::StrCat(k.fx(), ",", k.fy(), ",", k.cx(), ",", k.cy(), ",", k.width(), ",",
                                 k.height()));
  }
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);

  const std::string log = dir + "/renderer.log";
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addchdir_np(&actions, dir.c_str());
  posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log.c_str(),
                                   O_WRONLY | O_CREAT | O_TRUNC, 0600);
  posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
  pid_t pid = 0;
  const int spawned =
      posix_spawn(&pid, options.binary.c_str(), &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (spawned != 0) {
    return absl::InternalError(absl::StrCat("the model renderer cannot run: ", options.binary, ": ",
                                            std::strerror(spawned)));
  }
  const auto deadline =
      std::chrono::steady_clock::now() + std::chrono::seconds(options.timeout_seconds);
  int status = 0;
  bool timed_out = false;
  for (;;) {
    const pid_t done = waitpid(pid, &status, WNOHANG);
    if (done == pid) break;
    if (done < 0 && errno != EINTR) return absl::InternalError("the model renderer: waitpid");
    if (std::chrono::steady_clock::now() > deadline) {
      kill(pid, SIGKILL);
      timed_out = true;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(timed_out ? 1 : 20));
  }
  const std::string name = Echo(model);
  if (timed_out) {
    return absl::InvalidArgumentError(
        absl::StrCat("model: ", name, ": rendering took over ", options.timeout_seconds, " s"));
  }
  if (WIFSIGNALED(status)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "model: ", name, ": the model renderer died on it (signal ", WTERMSIG(status), ")"));
  }
  const int code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  if (code == 2) return absl::InvalidArgumentError(absl::StrCat("model: ", LastLine(log)));
  if (code != 0) {
    return absl::InternalError(
        absl::StrCat("the model renderer failed (exit status ", code, "): ", LastLine(log)));
  }
  return absl::OkStatus();
}

}  // namespace skimap::server
