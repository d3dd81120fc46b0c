#include "client/cli/stream_command.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <deque>
#include <iterator>
#include <map>
#include <memory>
#include <optional>
#include <thread>
#include <vector>

#include "absl/strings/str_cat.h"
#include "base/mutex.h"
#include "client/cli/frame_source.h"
#include "client/cli/map_option_flags.h"

namespace skimap::client {
namespace {

using Clock = std::chrono::steady_clock;

// The progress line on stderr; `total` 0: not known ahead (no bar).
void Progress(size_t done, size_t total, double seconds) {
  const double rate = seconds > 0 ? done / seconds : 0.0;
  if (total == 0) {
    std::fprintf(stderr, "\r%zu frames  %.1f frames/s ", done, rate);
    return;
  }
  constexpr int kBar = 30;
  const int filled = static_cast<int>(kBar * std::min(done, total) / total);
  std::fprintf(stderr, "\r[%s%s] %zu/%zu frames  %.1f frames/s ", std::string(filled, '#').c_str(),
               std::string(kBar - filled, ' ').c_str(), done, total, rate);
}

// The frames sent but not yet acknowledged, by sequence: on a redirect they go to the
// owner. Thread safety: Add and TakeAll on the sending thread, Ack on the reader thread.
class Unacked {
 public:
  void Add(std::shared_ptr<const v1::Frame> frame) {
    MutexLock lock(&mu_);
    frames_.emplace(frame->sequence(), std::move(frame));
  }
  void Ack(uint64_t sequence) {
    MutexLock lock(&mu_);
    frames_.erase(sequence);
  }
  // In sequence order; leaves none.
  std::vector<std::shared_ptr<const v1::Frame>> TakeAll() {
    MutexLock lock(&mu_);
    std::vector<std::shared_ptr<const v1::Frame>> all;
    for (auto& [sequence, frame] : frames_) all.push_back(std::move(frame));
    frames_.clear();
    return all;
  }

 private:
  Mutex mu_;
  std::map<uint64_t, std::shared_ptr<const v1::Frame>> frames_ ABSL_GUARDED_BY(mu_);
};

// The frames to send, in order: first those a redirect hands back, then the source's,
// numbered from first_sequence without gaps (a frame the source could not make takes no
// number, so that the next stream's first sequence, the map's frame count, is unused).
class Outbox {
 public:
  Outbox(FrameSource* source, std::string map_name, uint64_t first_sequence)
      : source_(source), map_name_(std::move(map_name)), first_sequence_(first_sequence) {}

  // The next frame, nullptr when there are no more.
  std::shared_ptr<const v1::Frame> Next() {
    if (!resend_.empty()) {
      std::shared_ptr<const v1::Frame> frame = std::move(resend_.front());
      resend_.pop_front();
      return frame;
    }
    while (!source_done_) {
      absl::StatusOr<std::optional<FrameOrError>> item = source_->Next();
      if (!item.ok() || !item->has_value()) {
        source_status_ = item.status();
        source_done_ = true;
        break;
      }
      FrameOrError& frame = **item;
      if (!frame.ok()) {
        if (first_frame_error_.ok()) first_frame_error_ = frame.status();
        continue;
      }
      frame->set_map(map_name_);
      frame->set_sequence(first_sequence_ + made_++);
      return std::make_shared<const v1::Frame>(*std::move(frame));
    }
    return nullptr;
  }
  // `frames` (in order) go out again before the rest.
  void Resend(std::vector<std::shared_ptr<const v1::Frame>> frames) {
    resend_.insert(resend_.begin(), std::make_move_iterator(frames.begin()),
                   std::make_move_iterator(frames.end()));
  }
  const absl::Status& source_status() const { return source_status_; }
  const absl::Status& first_frame_error() const { return first_frame_error_; }

 private:
  FrameSource* const source_;
  const std::string map_name_;
  const uint64_t first_sequence_;
  std::deque<std::shared_ptr<const v1::Frame>> resend_;
  uint64_t made_ = 0;  // frames numbered so far
  bool source_done_ = false;
  absl::Status source_status_;
  absl::Status first_frame_error_;
};

}  // namespace

absl::Status StreamDataset(MapClient& client, const std::string& dataset_path,
                           const StreamOptions& options) {
  FrameSourceOptions source_options;
  source_options.every = options.every;
  source_options.max_frames = options.max_frames;
  source_options.depth_encoding = options.depth_encoding;
  source_options.bag = options.bag;
  absl::StatusOr<std::unique_ptr<FrameSource>> source =
      OpenFrameSource(dataset_path, source_options);
  if (!source.ok()) return source.status();
  const std::string map_name = absl::StrCat("maps/", options.map_id);
  absl::StatusOr<v1::Map> map = client.GetMap(map_name);
  if (absl::IsNotFound(map.status())) {
    v1::CreateMapRequest create;
    create.set_map_id(options.map_id);
    *create.mutable_options() = options.map_options;
    create.mutable_options()->set_resolution(options.resolution);
    if (options.recognition.has_value()) {
      *create.mutable_options()->mutable_recognition() = *options.recognition;
    }
    map = client.CreateMap(create);
  }
  if (!map.ok()) return map.status();
  if (absl::Status s = CheckMapOptions(options.map_options, map->options(), map_name); !s.ok()) {
    return s;
  }
  const uint64_t first_sequence = map->stats().frames();  // continue after earlier streams

  // The source prepares frames ahead on its own threads (DatasetFrameSource) while this
  // thread sends and the window keeps the server busy.
  const size_t total = (*source)->total();
  Outbox outbox(source->get(), map_name, first_sequence);
  Unacked unacked;
  std::atomic<size_t> acked{0};
  const Clock::time_point start = Clock::now();
  auto elapsed = [&] { return std::chrono::duration<double>(Clock::now() - start).count(); };
  // Each frame's last ack, by sequence. A fleet node that does not serve the map answers
  // UNAVAILABLE with a redirect: the frames not yet acknowledged go to the owner.
  std::map<uint64_t, v1::FrameAck> acks;
  std::unique_ptr<MapClient> owner;  // the node a redirect named
  MapClient* target = &client;
  for (int hop = 0;; ++hop) {
    std::atomic<bool> redirected{false};
    FrameStream::Options stream_options;
    stream_options.window = options.window;
    stream_options.on_ack = [&](const v1::FrameAck& ack) {
      if (ack.has_redirect()) {
        redirected = true;
        return;
      }
      unacked.Ack(ack.sequence());
      const size_t n = ++acked;
      if (!options.quiet) Progress(n, total, elapsed());
    };
    std::unique_ptr<FrameStream> stream = target->OpenFrameStream(stream_options, map_name);
    while (!redirected) {
      std::shared_ptr<const v1::Frame> frame = outbox.Next();
      if (frame == nullptr) break;
      if (options.fps > 0) {
        std::this_thread::sleep_until(
            start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(
                        (frame->sequence() - first_sequence) / options.fps)));
      }
      unacked.Add(frame);
      if (absl::Status s = stream->Send(*frame); !s.ok()) break;  // Finish reports why
    }
    absl::StatusOr<std::vector<v1::FrameAck>> done = stream->Finish();
    if (!done.ok()) return done.status();
    std::optional<v1::MapRedirect> redirect;
    for (const v1::FrameAck& ack : *done) {
      if (ack.has_redirect()) {
        redirect = ack.redirect();
      } else {
        acks[ack.sequence()] = ack;
      }
    }
    if (!redirect.has_value()) break;
    if (hop >= 3) return absl::UnavailableError("stream: more than 3 redirects");
    outbox.Resend(unacked.TakeAll());
    owner = MapClient::Connect(redirect->address(), client.options());
    target = owner.get();
  }
  if (!options.quiet) std::fprintf(stderr, "\n");
  const double seconds = elapsed();
  absl::Status first_error = outbox.first_frame_error();
  size_t ok = 0;
  double integration_ms = 0;
  for (const auto& [sequence, ack] : acks) {
    if (ack.code() == 0) {
      ++ok;
      integration_ms +=
          ack.integration_time().seconds() * 1e3 + ack.integration_time().nanos() / 1e6;
    } else if (first_error.ok()) {
      first_error = absl::Status(static_cast<absl::StatusCode>(ack.code()),
                                 absl::StrCat("frame ", sequence, ": ", ack.message()));
    }
  }
  const size_t received = acks.size();
  // Quiet callers (skimap eval) print their own table on stdout: the summary goes to stderr.
  FILE* summary = options.quiet ? stderr : stdout;
  std::fprintf(summary,
               "streamed %zu frames to %s in %.2f s (%.1f frames/s): %zu ok, %zu failed, "
               "mean integration %.1f ms\n",
               received, map_name.c_str(), seconds, seconds > 0 ? received / seconds : 0, ok,
               received - ok, ok ? integration_ms / ok : 0.0);
  map = client.GetMap(map_name);
  if (map.ok()) {
    std::fprintf(summary, "map %s: %llu voxels, %llu frames, %.1f MiB\n", map_name.c_str(),
                 (unsigned long long)map->stats().voxels(),
                 (unsigned long long)map->stats().frames(),
                 map->stats().memory_bytes() / 1048576.0);
  }
  // A source that could not go on (a corrupt bag) says so before any frame's error.
  if (!outbox.source_status().ok()) return outbox.source_status();
  return first_error;
}

}  // namespace skimap::client
