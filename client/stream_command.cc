#include "client/stream_command.h"

#include <atomic>
#include <chrono>
#include <cstdio>
#include <thread>

#include "absl/strings/str_cat.h"
#include "client/dataset_frames.h"

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

absl::Status StreamDataset(MapClient& client, const std::string& dataset_path,
                           const StreamOptions& options) {
  absl::StatusOr<std::vector<dataset::Frame>> frames = LoadDatasetFrames(dataset_path);
  if (!frames.ok()) return frames.status();
  const std::string map_name = absl::StrCat("maps/", options.map_id);
  absl::StatusOr<v1::Map> map = client.GetMap(map_name);
  if (absl::IsNotFound(map.status())) {
    v1::CreateMapRequest create;
    create.set_map_id(options.map_id);
    create.mutable_options()->set_resolution(options.resolution);
    map = client.CreateMap(create);
  }
  if (!map.ok()) return map.status();
  const uint64_t first_sequence = map->stats().frames();  // continue after earlier streams

  const size_t total = frames->size();
  std::atomic<size_t> acked{0};
  const Clock::time_point start = Clock::now();
  auto elapsed = [&] { return std::chrono::duration<double>(Clock::now() - start).count(); };
  FrameStream::Options stream_options;
  stream_options.window = options.window;
  stream_options.on_ack = [&](const v1::FrameAck&) {
    const size_t n = ++acked;
    if (!options.quiet) Progress(n, total, elapsed());
  };
  std::unique_ptr<FrameStream> stream = client.OpenFrameStream(stream_options);
  absl::Status first_error;
  for (size_t i = 0; i < total; ++i) {
    if (options.fps > 0) {
      std::this_thread::sleep_until(start + std::chrono::duration_cast<Clock::duration>(
                                                std::chrono::duration<double>(i / options.fps)));
    }
    absl::StatusOr<v1::Frame> frame = ToApiFrame((*frames)[i], map_name, first_sequence + i);
    if (!frame.ok()) {
      if (first_error.ok()) first_error = frame.status();
      continue;
    }
    if (absl::Status s = stream->Send(*frame); !s.ok()) break;  // Finish reports why
  }
  absl::StatusOr<std::vector<v1::FrameAck>> acks = stream->Finish();
  if (!options.quiet) std::fprintf(stderr, "\n");
  if (!acks.ok()) return acks.status();
  const double seconds = elapsed();
  size_t ok = 0;
  double integration_ms = 0;
  for (const v1::FrameAck& ack : *acks) {
    if (ack.code() == 0) {
      ++ok;
      integration_ms +=
          ack.integration_time().seconds() * 1e3 + ack.integration_time().nanos() / 1e6;
    } else if (first_error.ok()) {
      first_error = absl::Status(static_cast<absl::StatusCode>(ack.code()),
                                 absl::StrCat("frame ", ack.sequence(), ": ", ack.message()));
    }
  }
  std::printf(
      "streamed %zu frames to %s in %.2f s (%.1f frames/s): %zu ok, %zu failed, "
      "mean integration %.1f ms\n",
      acks->size(), map_name.c_str(), seconds, seconds > 0 ? acks->size() / seconds : 0, ok,
      acks->size() - ok, ok ? integration_ms / ok : 0.0);
  map = client.GetMap(map_name);
  if (map.ok()) {
    std::printf("map %s: %llu voxels, %llu frames, %.1f MiB\n", map_name.c_str(),
                (unsigned long long)map->stats().voxels(),
                (unsigned long long)map->stats().frames(), map->stats().memory_bytes() / 1048576.0);
  }
  return first_error;
}

}  // namespace skimap::client
