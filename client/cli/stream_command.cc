#include "client/cli/stream_command.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <optional>
#include <thread>
#include <vector>

#include "absl/strings/str_cat.h"
#include "client/cli/dataset_frames.h"
#include "client/cli/map_option_flags.h"

namespace skimap::client {
namespace {

using Clock = std::chrono::steady_clock;

void Progress(size_t done, size_t total, double seconds) {
  constexpr int kBar = 30;
  const int filled = total == 0 ? kBar : static_cast<int>(kBar * done / total);
  std::fprintf(stderr, "\r[%s%s] %zu/%zu frames  %.1f frames/s ", std::string(filled, '#').c_str(),
               std::string(kBar - filled, ' ').c_str(), done, total,
               seconds > 0 ? done / seconds : 0.0);
}

}  // namespace

std::vector<dataset::Frame> KeepEvery(std::vector<dataset::Frame> frames, int every,
                                      int max_frames) {
  if (every <= 1 && max_frames <= 0) return frames;
  std::vector<dataset::Frame> kept;
  for (size_t i = 0; i < frames.size(); i += std::max(1, every)) {
    if (max_frames > 0 && static_cast<int>(kept.size()) >= max_frames) break;
    kept.push_back(std::move(frames[i]));
  }
  return kept;
}

absl::Status StreamDataset(MapClient& client, const std::string& dataset_path,
                           const StreamOptions& options) {
  absl::StatusOr<std::vector<dataset::Frame>> frames = LoadDatasetFrames(dataset_path);
  if (!frames.ok()) return frames.status();
  *frames = KeepEvery(*std::move(frames), options.every, options.max_frames);
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

  const size_t total = frames->size();
  std::atomic<size_t> acked{0};
  const Clock::time_point start = Clock::now();
  auto elapsed = [&] { return std::chrono::duration<double>(Clock::now() - start).count(); };
  absl::Status first_error;
  // acks[i]: frame i's ack. A fleet node that does not serve the map answers UNAVAILABLE
  // with a redirect: the frames from the first redirected one on go to the owner.
  std::vector<std::optional<v1::FrameAck>> acks(total);
  std::unique_ptr<MapClient> owner;  // the node a redirect named
  MapClient* target = &client;
  size_t next = 0;
  for (int hop = 0; next < total; ++hop) {
    std::atomic<bool> redirected{false};
    FrameStream::Options stream_options;
    stream_options.window = options.window;
    stream_options.on_ack = [&](const v1::FrameAck& ack) {
      if (ack.has_redirect()) {
        redirected = true;
        return;
      }
      const size_t n = ++acked;
      if (!options.quiet) Progress(n, total, elapsed());
    };
    std::unique_ptr<FrameStream> stream = target->OpenFrameStream(stream_options, map_name);
    size_t sent = next;
    for (; sent < total && !redirected; ++sent) {
      if (options.fps > 0) {
        std::this_thread::sleep_until(start +
                                      std::chrono::duration_cast<Clock::duration>(
                                          std::chrono::duration<double>(sent / options.fps)));
      }
      absl::StatusOr<v1::Frame> frame =
          ToApiFrame((*frames)[sent], map_name, first_sequence + sent, options.depth_encoding);
      if (!frame.ok()) {
        if (first_error.ok()) first_error = frame.status();
        continue;
      }
      if (absl::Status s = stream->Send(*frame); !s.ok()) break;  // Finish reports why
    }
    absl::StatusOr<std::vector<v1::FrameAck>> done = stream->Finish();
    if (!done.ok()) return done.status();
    std::optional<v1::MapRedirect> redirect;
    size_t resend = sent;
    for (const v1::FrameAck& ack : *done) {
      const size_t i = ack.sequence() - first_sequence;
      if (i >= total) continue;
      if (ack.has_redirect()) {
        redirect = ack.redirect();
        resend = std::min(resend, i);
      } else {
        acks[i] = ack;
      }
    }
    next = resend;
    if (!redirect.has_value()) {
      next = sent;
      break;
    }
    if (hop >= 3) return absl::UnavailableError("stream: more than 3 redirects");
    owner = MapClient::Connect(redirect->address(), client.options());
    target = owner.get();
  }
  if (!options.quiet) std::fprintf(stderr, "\n");
  const double seconds = elapsed();
  size_t ok = 0, received = 0;
  double integration_ms = 0;
  for (const std::optional<v1::FrameAck>& ack : acks) {
    if (!ack.has_value()) continue;
    ++received;
    if (ack->code() == 0) {
      ++ok;
      integration_ms +=
          ack->integration_time().seconds() * 1e3 + ack->integration_time().nanos() / 1e6;
    } else if (first_error.ok()) {
      first_error = absl::Status(static_cast<absl::StatusCode>(ack->code()),
                                 absl::StrCat("frame ", ack->sequence(), ": ", ack->message()));
    }
  }
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
  return first_error;
}

}  // namespace skimap::client
