#include "client/cli/bag_frame_source.h"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <cstring>
#include <deque>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <thread>

#include "absl/strings/str_cat.h"
#include "client/frame_depth.h"

extern char** environ;

namespace skimap::client {
namespace {

// Frames read ahead of the stream: a few, so a bag's memory stays bounded.
constexpr size_t kReadAhead = 8;

class BagFrameSource final : public FrameSource {
 public:
  BagFrameSource(std::unique_ptr<bag::BagFrames> bag, const bag::BagFrameOptions& options,
                 v1::DepthEncoding encoding)
      : bag_(std::move(bag)), options_(options), encoding_(encoding), stats_(bag_->chosen()) {
    if (const uint64_t n = bag_->depth_images(); n > 0) {
      total_ = (n + std::max(1, options.every) - 1) / std::max(1, options.every);
      if (options.max_frames > 0) total_ = std::min<size_t>(total_, options.max_frames);
    }
    reader_ = std::thread([this] { Read(); });
  }

  ~BagFrameSource() override {
    {
      std::lock_guard<std::mutex> lock(mu_);
      stop_ = true;
    }
    cv_.notify_all();
    reader_.join();
    PrintNotes();
  }

  size_t total() const override { return total_; }

  absl::StatusOr<std::optional<FrameOrError>> Next() override {
    std::unique_lock<std::mutex> lock(mu_);
    cv_.wait(lock, [&] { return !queue_.empty() || done_; });
    if (queue_.empty()) {
      if (!end_.ok()) return end_;
      return std::optional<FrameOrError>();
    }
    FrameOrError frame = std::move(queue_.front());
    queue_.pop_front();
    cv_.notify_all();
    return std::optional<FrameOrError>(std::move(frame));
  }

 private:
  void Read() {
    absl::Status s = bag_->Read(
        [&](absl::StatusOr<bag::RosFrame> made) -> absl::Status {
          absl::Status error = made.status();
          if (made.ok()) {
            error = SetFrameDepth(made->depth_mm.data(), made->width, made->height, &made->frame,
                                  encoding_);
          }
          FrameOrError frame =
              error.ok() ? FrameOrError(std::move(made->frame)) : FrameOrError(error);
          std::unique_lock<std::mutex> lock(mu_);
          cv_.wait(lock, [&] { return queue_.size() < kReadAhead || stop_; });
          if (stop_) return absl::CancelledError("stream stopped");
          queue_.push_back(std::move(frame));
          cv_.notify_all();
          return absl::OkStatus();
        },
        &stats_);
    std::lock_guard<std::mutex> lock(mu_);
    if (!stop_) end_ = s;
    done_ = true;
    cv_.notify_all();
  }

  // What the read skipped, on stderr after the stream's summary.
  void PrintNotes() const {
    std::fprintf(stderr,
                 "bag: depth %s, colour %s, camera_info %s, poses in %s: %llu depth "
                 "images, %llu frames",
                 stats_.depth_topic.c_str(),
                 stats_.color_topic.empty() ? "(none)" : stats_.color_topic.c_str(),
                 stats_.camera_info_topic.c_str(), stats_.fixed_frame.c_str(),
                 (unsigned long long)stats_.depth_images, (unsigned long long)stats_.frames);
    if (stats_.without_color > 0) {
      std::fprintf(stderr, ", %llu skipped without a colour image within %.3f s",
                   (unsigned long long)stats_.without_color, options_.sync_tolerance);
    }
    if (stats_.without_pose > 0) {
      std::fprintf(stderr, ", %llu skipped without a pose (first: %s)",
                   (unsigned long long)stats_.without_pose, stats_.first_pose_error.c_str());
    }
    std::fprintf(stderr, "\n");
  }

  const std::unique_ptr<bag::BagFrames> bag_;
  const bag::BagFrameOptions options_;
  const v1::DepthEncoding encoding_;
  bag::BagFrameStats stats_;  // written by the reader thread until it ends
  size_t total_ = 0;
  std::mutex mu_;
  std::condition_variable cv_;
  std::deque<FrameOrError> queue_;  // guarded by mu_
  bool stop_ = false;               // guarded by mu_
  bool done_ = false;               // guarded by mu_
  absl::Status end_;                // guarded by mu_
  std::thread reader_;
};

bool IsRos1Bag(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  char magic[12] = {};
  in.read(magic, sizeof magic);
  return in.gcount() == sizeof magic && std::memcmp(magic, "#ROSBAG V2.0", sizeof magic) == 0;
}

// The child's time for the bag at `path` when the caller leaves it to us: 60 s plus 1 s per
// 20 MB (rosbag reads a few hundred MB/s here).
double DefaultCheckSeconds(const std::string& path) {
  std::error_code ec;
  const uintmax_t bytes = std::filesystem::file_size(path, ec);
  return 60 + (ec ? 0 : static_cast<double>(bytes) / 20e6);
}

// Reads the ROS 1 bag at `path` in a child process first (bag_frame_source.h), for at most
// `limit_seconds`.
absl::Status CheckRos1BagInChild(const std::string& path, double limit_seconds) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, "/dev/null", O_WRONLY, 0);
  std::string self = "/proc/self/exe", command = "__read-ros1-bag", file = path;
  std::vector<char*> argv = {self.data(), command.data(), file.data(), nullptr};
  pid_t pid = 0;
  const int rc = posix_spawn(&pid, self.c_str(), &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0) {
    return absl::InternalError(absl::StrCat("cannot start the bag check: ", std::strerror(rc)));
  }
  const auto start = std::chrono::steady_clock::now();
  const auto limit = std::chrono::duration<double>(limit_seconds);
  int status = 0;
  bool timed_out = false;
  for (;;) {
    const pid_t r = waitpid(pid, &status, WNOHANG);
    if (r == pid || (r < 0 && errno != EINTR)) break;
    if (!timed_out && std::chrono::steady_clock::now() - start > limit) {
      timed_out = true;  // killed, then reaped by the next waitpid
      kill(pid, SIGKILL);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  if (timed_out) {
    return absl::InvalidArgumentError(absl::StrCat(
        path, ": the ROS 1 bag library (Debian's rosbag) took more than ", limit_seconds,
        " s to read this file (--bag_check_seconds): it is damaged, hostile or too large for "
        "the limit; nothing was streamed"));
  }
  if (WIFSIGNALED(status)) {
    return absl::InvalidArgumentError(absl::StrCat(
        path, ": the ROS 1 bag library (Debian's rosbag) crashed reading this file (signal ",
        WTERMSIG(status), "): it is damaged or hostile; nothing was streamed"));
  }
  return absl::OkStatus();  // read, or refused: this process's own read says why
}

}  // namespace

int ReadRos1BagInThisProcess(const std::string& path) {
  return bag::ReadAllFrameMessages(path).ok() ? 0 : 1;
}

absl::StatusOr<std::unique_ptr<FrameSource>> OpenBagFrameSource(const std::string& path,
                                                                const bag::BagFrameOptions& options,
                                                                v1::DepthEncoding depth_encoding,
                                                                double check_seconds) {
  if (IsRos1Bag(path)) {
    const double limit = check_seconds > 0 ? check_seconds : DefaultCheckSeconds(path);
    if (absl::Status s = CheckRos1BagInChild(path, limit); !s.ok()) return s;
  }
  absl::StatusOr<std::unique_ptr<bag::BagFrames>> bag = bag::BagFrames::Open(path, options);
  if (!bag.ok()) return bag.status();
  // A bag's depth arrives decoded: there is no file to send as stored.
  if (depth_encoding == kDepthAsStored) depth_encoding = kDefaultDepthEncoding;
  return std::make_unique<BagFrameSource>(*std::move(bag), options, depth_encoding);
}

}  // namespace skimap::client
