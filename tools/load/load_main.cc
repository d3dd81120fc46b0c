// skimap-load: a load and soak run against a real skimapd, loopback only, for a fixed
// duration. N robot streams (gRPC StreamFrames, frames of new space, one map each) and M
// query clients (half gRPC, half REST: occupancy grids, voxel pages, radius searches near
// the robots) run at once while skimapd's resident memory (VmRSS, /proc/<pid>/status) and
// its maps' memory (skimap_map_memory_bytes from GET /metrics) are sampled.
//
//   skimap-load --skimapd=build/release/server/skimapd --streams=4 --clients=8 --duration_s=300
//   skimap-load --target=127.0.0.1:50051 --http_port=8080 --pid=1234 ...   (a running one)
//
// Reports frames/s, query p50/p99 per kind, RSS over time and error counts. Exits 1 on any
// error (a refused frame, a failed query, skimapd gone) or when, over the second half of
// the run, RSS grows faster than the maps' own memory by more than
// --max_rss_slope_mb_per_min (a leak: memory that no map accounts for); 2 on bad flags.
#include <arpa/inet.h>
#include <fcntl.h>
#include <httplib.h>
#include <netinet/in.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "absl/flags/flag.h"
#include "absl/flags/parse.h"
#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "tools/load/load_clients.h"

ABSL_FLAG(std::string, skimapd, "", "skimapd binary to start (loopback ports, a temp data dir)");
ABSL_FLAG(std::string, target, "", "or: a running skimapd's gRPC address (127.0.0.1:PORT)");
ABSL_FLAG(int, http_port, 0, "with --target: its REST port on 127.0.0.1");
ABSL_FLAG(int, pid, 0, "with --target: its process id (for RSS)");
ABSL_FLAG(int, streams, 4, "robot streams (one map each)");
ABSL_FLAG(int, clients, 8, "query clients (half gRPC, half REST)");
ABSL_FLAG(int, duration_s, 60, "seconds of load (1 .. 86400)");
ABSL_FLAG(double, fps, 15, "frames per second per stream at most");
ABSL_FLAG(int, think_ms, 20, "pause of a query client between queries");
ABSL_FLAG(int, worker_threads, 2, "--worker_threads of the skimapd started here");
ABSL_FLAG(double, max_rss_slope_mb_per_min, 16,
          "largest growth of RSS beyond the maps' own memory over the second half, MiB/min");

namespace skimap::load {
namespace {

using Clock = std::chrono::steady_clock;

int FreePort() {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a);
  socklen_t n = sizeof a;
  getsockname(fd, reinterpret_cast<sockaddr*>(&a), &n);
  close(fd);
  return ntohs(a.sin_port);
}

double RssMiB(int pid) {
  std::ifstream status(absl::StrCat("/proc/", pid, "/status"));
  std::string key;
  while (status >> key) {
    if (key == "VmRSS:") {
      double kb = 0;
      status >> kb;
      return kb / 1024;
    }
    status.ignore(1 << 10, '\n');
  }
  return -1;
}

// Sum of skimap_map_memory_bytes over the maps, MiB; -1 if the scrape failed.
double MapMiB(httplib::Client& http) {
  httplib::Result r = http.Get("/metrics");
  if (!r || r->status != 200) return -1;
  std::istringstream in(r->body);
  std::string line;
  double bytes = 0;
  while (std::getline(in, line)) {
    if (!absl::StartsWith(line, "skimap_map_memory_bytes{")) continue;
    double v = 0;
    if (absl::SimpleAtod(line.substr(line.rfind(' ') + 1), &v)) bytes += v;
  }
  return bytes / (1 << 20);
}

double Percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(q * static_cast<double>(v.size())))];
}

// Least-squares slope of y over t (minutes).
double Slope(const std::vector<double>& t, const std::vector<double>& y) {
  const double n = static_cast<double>(t.size());
  if (n < 2) return 0;
  double st = 0, sy = 0, stt = 0, sty = 0;
  for (size_t i = 0; i < t.size(); ++i) {
    st += t[i];
    sy += y[i];
    stt += t[i] * t[i];
    sty += t[i] * y[i];
  }
  const double d = n * stt - st * st;
  return d == 0 ? 0 : (n * sty - st * sy) / d;
}

struct Sample {
  double t_s, rss_mib, map_mib;
};

int Main() {
  const int streams = absl::GetFlag(FLAGS_streams), clients = absl::GetFlag(FLAGS_clients);
  const int duration = absl::GetFlag(FLAGS_duration_s);
  if (streams < 1 || clients < 0 || duration < 1 || duration > 86400 ||
      absl::GetFlag(FLAGS_fps) <= 0 ||
      absl::GetFlag(FLAGS_skimapd).empty() == absl::GetFlag(FLAGS_target).empty()) {
    std::fprintf(stderr, "skimap-load: give --skimapd or --target; see --help\n");
    return 2;
  }
  std::string address = absl::GetFlag(FLAGS_target);
  int http_port = absl::GetFlag(FLAGS_http_port), pid = absl::GetFlag(FLAGS_pid);
  std::string data_dir;
  if (!address.empty() && !absl::StartsWith(address, "127.0.0.1:") &&
      !absl::StartsWith(address, "localhost:") && !absl::StartsWith(address, "[::1]:")) {
    std::fprintf(stderr, "skimap-load: loopback targets only (--target=127.0.0.1:PORT)\n");
    return 2;
  }
  if (address.empty()) {
    data_dir =
        (std::filesystem::temp_directory_path() / absl::StrCat("skimap_load_", getpid())).string();
    std::filesystem::create_directories(data_dir);
    address = absl::StrCat("127.0.0.1:", FreePort());
    http_port = FreePort();
    std::vector<std::string> args = {
        absl::GetFlag(FLAGS_skimapd),
        "--address=" + address,
        absl::StrCat("--http_address=127.0.0.1:", http_port),
        "--data_dir=" + data_dir + "/data",
        absl::StrCat("--worker_threads=", absl::GetFlag(FLAGS_worker_threads)),
        "--web_root="};
    // posix_spawn, not fork: nothing may allocate in a child of a threaded process.
    const std::string log = data_dir + "/skimapd.log";
    std::vector<char*> argv;
    for (std::string& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 1, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
    posix_spawn_file_actions_adddup2(&actions, 1, 2);
    const int spawned = posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    if (spawned != 0) {
      std::fprintf(stderr, "skimap-load: cannot start %s\n", argv[0]);
      return 1;
    }
  }
  auto channel = grpc::CreateChannel(address, grpc::InsecureChannelCredentials());
  if (!channel->WaitForConnected(std::chrono::system_clock::now() + std::chrono::seconds(20))) {
    std::fprintf(stderr, "skimap-load: skimapd at %s did not answer\n", address.c_str());
    if (!data_dir.empty()) kill(pid, SIGKILL);
    return 1;
  }
  auto stub = v1::MapService::NewStub(channel);
  std::vector<std::string> maps;
  for (int i = 0; i < streams; ++i) {
    const std::string id = absl::StrCat("load", getpid(), "_", i);
    grpc::ClientContext ctx;
    v1::CreateMapRequest create;
    create.set_map_id(id);
    v1::Map map;
    if (grpc::Status s = stub->CreateMap(&ctx, create, &map); !s.ok()) {
      std::fprintf(stderr, "skimap-load: CreateMap %s: %s\n", id.c_str(),
                   s.error_message().c_str());
      return 1;
    }
    maps.push_back("maps/" + id);
  }

  std::vector<std::unique_ptr<RobotStream>> robots;
  std::vector<RobotStream*> robot_ptrs;
  for (int i = 0; i < streams; ++i) {
    robots.push_back(std::make_unique<RobotStream>(
        stub.get(),
        RobotStream::Options{.map = maps[i], .index = i, .fps = absl::GetFlag(FLAGS_fps)}));
    robot_ptrs.push_back(robots.back().get());
  }
  std::vector<std::unique_ptr<QueryClient>> queries;
  for (int i = 0; i < clients; ++i) {
    queries.push_back(std::make_unique<QueryClient>(
        stub.get(), robot_ptrs, maps,
        QueryClient::Options{.rest = i % 2 == 1,
                             .http_port = http_port,
                             .think_ms = absl::GetFlag(FLAGS_think_ms),
                             .seed = static_cast<uint32_t>(i + 1)}));
  }
  std::printf(
      "skimap-load: %d streams x %.0f fps, %d query clients (%d gRPC, %d REST), %d s, "
      "skimapd pid %d\n",
      streams, absl::GetFlag(FLAGS_fps), clients, (clients + 1) / 2, clients / 2, duration, pid);
  std::fflush(stdout);
  const Clock::time_point start = Clock::now();
  for (auto& r : robots) r->Start();
  for (auto& q : queries) q->Start();

  httplib::Client http("127.0.0.1", http_port);
  std::vector<Sample> samples;
  bool died = false;
  // About one sample a second, for `duration` seconds whatever a scrape takes.
  const Clock::time_point end = start + std::chrono::seconds(duration);
  for (int s = 0;; ++s) {
    std::this_thread::sleep_until(std::min(end, start + std::chrono::seconds(s)));
    const double t = std::chrono::duration<double>(Clock::now() - start).count();
    const double rss = RssMiB(pid);
    if (rss < 0) {
      died = true;
      break;
    }
    samples.push_back({t, rss, MapMiB(http)});
    if (Clock::now() >= end) break;
    s = std::max(s, static_cast<int>(t));
  }
  for (auto& q : queries) q->Stop();
  for (auto& r : robots) r->Stop();
  const double seconds = std::chrono::duration<double>(Clock::now() - start).count();

  uint64_t frames = 0, errors = 0;
  std::string first_error;
  for (auto& r : robots) {
    frames += r->frames_acked();
    errors += r->errors();
    if (first_error.empty()) first_error = r->first_error();
  }
  std::printf("frames: %llu acknowledged, %.1f frames/s, %llu refused or failed\n",
              static_cast<unsigned long long>(frames), static_cast<double>(frames) / seconds,
              static_cast<unsigned long long>(errors));
  std::map<std::string, std::vector<double>> latency;
  std::map<std::string, uint64_t> query_errors;
  for (auto& q : queries) {
    for (const auto& [kind, v] : q->log().latency_ms) {
      latency[kind].insert(latency[kind].end(), v.begin(), v.end());
    }
    for (const auto& [kind, n] : q->log().errors) query_errors[kind] += n;
    if (first_error.empty()) first_error = q->log().first_error;
  }
  std::printf("%-14s %8s %9s %9s %7s\n", "query", "count", "p50 ms", "p99 ms", "errors");
  for (const auto& [kind, v] : latency) {
    std::printf("%-14s %8zu %9.2f %9.2f %7llu\n", kind.c_str(), v.size(), Percentile(v, 0.5),
                Percentile(v, 0.99), static_cast<unsigned long long>(query_errors[kind]));
    errors += query_errors[kind];
  }
  std::printf("%-8s %9s %13s\n", "t (s)", "RSS MiB", "maps MiB");
  const size_t every = std::max<size_t>(1, samples.size() / 10);
  for (size_t i = 0; i < samples.size(); i += every) {
    std::printf("%-8.0f %9.1f %13.1f\n", samples[i].t_s, samples[i].rss_mib, samples[i].map_mib);
  }
  if (!samples.empty() && (samples.size() - 1) % every != 0) {
    const Sample& l = samples.back();
    std::printf("%-8.0f %9.1f %13.1f\n", l.t_s, l.rss_mib, l.map_mib);
  }
  std::vector<double> t, rss, unexplained;
  for (const Sample& s : samples) {
    if (s.t_s < duration / 2.0 || s.map_mib < 0) continue;
    t.push_back(s.t_s / 60);
    rss.push_back(s.rss_mib);
    unexplained.push_back(s.rss_mib - s.map_mib);
  }
  const double rss_slope = Slope(t, rss), leak_slope = Slope(t, unexplained);
  const double limit = absl::GetFlag(FLAGS_max_rss_slope_mb_per_min);
  std::printf(
      "second half: RSS %+.2f MiB/min, RSS beyond the maps' memory %+.2f MiB/min "
      "(limit %.2f)\n",
      rss_slope, leak_slope, limit);

  int exit_code = 0;
  if (died) {
    std::printf("FAIL: skimapd (pid %d) is gone\n", pid);
    exit_code = 1;
  }
  if (errors > 0) {
    std::printf("FAIL: %llu errors; the first: %s\n", static_cast<unsigned long long>(errors),
                first_error.c_str());
    exit_code = 1;
  }
  if (leak_slope > limit) {
    std::printf("FAIL: memory grows beyond the maps' own by %.2f MiB/min\n", leak_slope);
    exit_code = 1;
  }
  if (frames == 0) {
    std::printf("FAIL: no frame acknowledged\n");
    exit_code = 1;
  }
  if (!data_dir.empty()) {
    kill(pid, SIGTERM);
    waitpid(pid, nullptr, 0);
    std::filesystem::remove_all(data_dir);
  }
  std::printf("%s\n", exit_code == 0 ? "PASS" : "FAIL");
  return exit_code;
}

}  // namespace
}  // namespace skimap::load

int main(int argc, char** argv) {
  absl::ParseCommandLine(argc, argv);
  return skimap::load::Main();
}
