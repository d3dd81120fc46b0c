// ingest_bench: the server-side path of one real RGB-D frame (issue 15; docs/benchmarks.md,
// "Ingestion"), side by side with Open3D's ScalableTSDFVolume in the same run. A plain
// program, not a test:
//
//   build/bench/bench/ingest_bench [--ycbv=DIR] [--reps=5] [--resolutions=0.01,0.02,0.05]
//       [--worker_threads=2] [--laps=3] [--window=8]
//
// Frames: the 10 real 640x480 frames of ycbv-0000 (BOP layout, dataset/reader.h), encoded
// per codec combination (depth raw / PNG16 / zstd / RVL, colour raw / PNG / JPEG q90) as a
// client sends them. Ours runs what skimapd runs for a frame of StreamFrames after gRPC
// has parsed it: LiveMap::SubmitFrame (server/core/maps/live_map.h) on an in-memory map (no
// journal), i.e. DecodeFrame (decode + validate), ValidatePoseInMap, the frame stages
// (back-projection + VoxelBatch, perception::BuildFrameBatch) and their Apply
// (SkiMap::Integrate under the snapshot lock), on the server's ThreadPool
// (--worker_threads, skimapd's default 2), timed from SubmitFrame to the ack callback.
//
//  1. Codec costs (bench/codec_costs.h).
//  1b. PNG files as stored (--png_dirs; default the ycbv rgb/ and depth/ folders): our
//     decoder against libpng alone, the same pixels checked (bench/codec_costs.h).
//  2. Per frame, new space: every sample integrates one frame into a fresh map (every
//     voxel is new); median and p90 over reps x 10 frames. "decode excluded" runs the same
//     stages on the already decoded frame (the work Open3D is given), split into Stage
//     (back-projection + batch) and Apply (integration).
//     Open3D 0.16 (Debian): ScalableTSDFVolume(voxel, sdf_trunc = 4 voxels, RGB8,
//     volume_unit_resolution 16, depth_sampling_stride 4) Integrate on the same decoded
//     images, a fresh volume per sample; its images are decoded and converted to
//     open3d::geometry::RGBDImage before the clock starts (Open3D gets decoded images). It
//     runs with its OpenMP team (one thread per core) and with one thread; ratios are to
//     the faster. Every timed run (ours and Open3D's) runs on a thread of its own, as a
//     map's worker: on the main thread, beside Open3D's OpenMP team, both were slower.
//     Re-observed space: the same frames again into a map / volume that holds them (ours
//     zstd + JPEG, the client library's default; Open3D both thread settings), Open3D's
//     usual use.
//  3. Stream throughput, new space: `laps` x 10 frames, each frame's pose moved 10 m
//     further along x (so every frame lands in new space), submitted with `window` frames
//     in flight into one map; frames/s. Open3D integrates the same frames into one volume.
//
// Maps decode ahead on shared decoder threads as skimapd's MapService does; the stream run
// also shows each codec with frames decoded on the worker (no decode-ahead) beside it.
//
// The variants run interleaved (frame by frame) so a loaded machine slows all of them
// alike; ratios are ours / Open3D's.
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <future>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "absl/flags/flag.h"
#include "absl/flags/parse.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_split.h"
#include "bench/codec_costs.h"
#include "bench/samples.h"
#include "bench/ycbv_frames.h"
#include "server/app/malloc_tuning.h"
#include "server/core/common/work_queue.h"
#include "server/core/maps/frame_decode.h"
#include "server/core/maps/frame_stages.h"
#include "server/core/maps/live_map.h"
#include "server/core/maps/map_config.h"
#include "server/core/maps/map_state.h"

#ifdef SKIMAP_BENCH_OPEN3D
#include <omp.h>

#include "bench/open3d_peer.h"
#endif

namespace {
// Open3D's OpenMP threads (its rows only print with the peer built in).
int PeerThreads() {
#ifdef SKIMAP_BENCH_OPEN3D
  return omp_get_num_procs();
#else
  return 0;
#endif
}
}  // namespace

ABSL_FLAG(std::string, ycbv, SKIMAP_BENCH_YCBV_DIR, "the ycbv-0000 BOP dataset root");
ABSL_FLAG(int, reps, 5, "samples per frame and variant");
ABSL_FLAG(std::string, resolutions, "0.01,0.02,0.05", "voxel edges, metres");
ABSL_FLAG(int, worker_threads, 2, "the server's integration threads (skimapd --worker_threads)");
ABSL_FLAG(int, laps, 3, "throughput run: laps over the 10 frames");
ABSL_FLAG(int, window, 8, "throughput run: frames in flight");
ABSL_FLAG(std::string, png_dirs, "",
          "section png: folders of PNG files (default: the ycbv scene's rgb/ and depth/)");
ABSL_FLAG(std::string, sections, "codecs,png,fresh,reobserved,running,stream",
          "which parts to run (all by default)");

namespace skimap::bench {
namespace {

namespace v1 = skimap::v1;

[[noreturn]] void Die(const std::string& what) {
  std::fprintf(stderr, "ingest_bench: %s\n", what.c_str());
  std::exit(1);
}

// The frames of one codec combination, `laps` x the 10 frames, frame k moved k * shift_m
// along world x.
std::vector<std::shared_ptr<const v1::Frame>> Encode(const std::vector<RealFrame>& frames,
                                                     const Codec& codec, int laps, double shift_m) {
  return EncodeFrames(frames, codec, size_t(laps) * frames.size(),
                      [&](size_t k) { return Shift{.x = double(k) * shift_m}; });
}

server::MapConfig Config(double resolution) {
  v1::MapOptions options;
  options.set_resolution(resolution);
  absl::StatusOr<server::MapConfig> config = server::ResolveMapOptions(options);
  if (!config.ok()) Die(config.status().ToString());
  return *config;
}

// Submits `frames` to `map` with at most `window` in flight; returns when every ack came.
void Stream(server::LiveMap& map, const std::vector<std::shared_ptr<const v1::Frame>>& frames,
            size_t window) {
  std::mutex mu;
  std::condition_variable cv;
  size_t in_flight = 0, acked = 0;
  std::string error;
  for (const auto& f : frames) {
    {
      std::unique_lock<std::mutex> lock(mu);
      cv.wait(lock, [&] { return in_flight < window; });
      ++in_flight;
    }
    map.SubmitFrame(f, [&](absl::StatusOr<v1::FrameAck> ack) {
      std::lock_guard<std::mutex> lock(mu);
      if (!ack.ok()) error = ack.status().ToString();
      --in_flight;
      ++acked;
      cv.notify_all();
    });
  }
  std::unique_lock<std::mutex> lock(mu);
  cv.wait(lock, [&] { return acked == frames.size(); });
  if (!error.empty()) Die(error);
}

// 2c. Per frame into a running map, new space: the server's steady state. One map (one
// Open3D volume per thread setting) takes a warm-up lap of the 10 frames, then reps x 10
// more, one at a time (the next is sent after the previous one's ack), every frame moved
// 10 m further along x so that all its voxels (volume units) are new. Ours: zstd + JPEG
// (the client library's default) through LiveMap::SubmitFrame (decode included), and the same
// frames already decoded through a running MapState's stages (decode excluded); Open3D: Integrate
// of the decoded frames into its running volume.
void RunningMap(const std::vector<RealFrame>& frames, const server::MapConfig& config,
                const server::LiveMap::Options& map_options, ThreadPool& pool,
                server::WorkQueue& runner, int reps) {
  const int laps = reps + 1;  // the first lap warms up and is not timed
  const auto encoded = Encode(frames, kZstdJpeg, laps, 10.0);
  std::vector<perception::RgbdFrame> decoded;
  for (const auto& f : encoded) decoded.push_back(*server::DecodeFrame(*f));
  const size_t warm = frames.size();
  Samples ours, excluded, o3d_team, o3d_one;
  {
    server::LiveMap map("bench", map_options);
    for (size_t k = 0; k < encoded.size(); ++k) {
      std::promise<absl::StatusOr<v1::FrameAck>> done;
      const Clock::time_point t0 = Clock::now();
      map.SubmitFrame(encoded[k],
                      [&](absl::StatusOr<v1::FrameAck> ack) { done.set_value(std::move(ack)); });
      if (absl::StatusOr<v1::FrameAck> ack = done.get_future().get(); !ack.ok()) {
        Die(ack.status().ToString());
      }
      if (k >= warm) ours.Add(Ms(Clock::now() - t0));
    }
  }
  runner.Run([&] {
    server::MapState state(config, &pool);
    auto stages = server::MakeFrameStages(config, Grid(config.resolution), &pool);
    for (size_t k = 0; k < decoded.size(); ++k) {
      const Clock::time_point t0 = Clock::now();
      for (auto& s : stages) s->Stage(decoded[k], server::FrameStage::kAdd);
      for (auto& s : stages) s->Apply(&state);
      if (k >= warm) excluded.Add(Ms(Clock::now() - t0));
    }
  });
  double peer = 0;
#ifdef SKIMAP_BENCH_OPEN3D
  std::vector<Open3dFrame> moved;
  for (size_t k = 0; k < encoded.size(); ++k) {
    moved.push_back(ToOpen3d(frames[k % frames.size()], double(k) * 10, 5.0));
  }
  for (const int threads : {0, 1}) {
    runner.Run([&] {
      omp_set_num_threads(threads == 0 ? omp_get_num_procs() : threads);
      auto volume = NewVolume(config.resolution);
      for (size_t k = 0; k < moved.size(); ++k) {
        const Clock::time_point t0 = Clock::now();
        volume->Integrate(*moved[k].rgbd, moved[k].intrinsic, moved[k].extrinsic);
        if (k >= warm) (threads == 0 ? o3d_team : o3d_one).Add(Ms(Clock::now() - t0));
      }
    });
  }
  peer = std::min(o3d_team.Median(), o3d_one.Median());
#endif
  auto ratio = [&](double v) {
    return peer > 0 ? absl::StrFormat("%.2f", v / peer) : std::string("-");
  };
  std::printf(
      "\n### Per frame into a running map, new space, %.0f cm (median / p90 ms over %d "
      "frames after a warm-up lap)\n\n| variant | ms (median) | p90 | / Open3D |\n"
      "|---|---|---|---|\n",
      config.resolution * 100, reps * int(frames.size()));
  std::printf("| ours, zstd + JPEG, decode included | %.2f | %.2f | %s |\n", ours.Median(),
              ours.Quantile(0.9), ratio(ours.Median()).c_str());
  std::printf("| ours, decode excluded | %.2f | %.2f | %s |\n", excluded.Median(),
              excluded.Quantile(0.9), ratio(excluded.Median()).c_str());
#ifdef SKIMAP_BENCH_OPEN3D
  std::printf("| Open3D, %d OpenMP threads (decoded images) | %.2f | %.2f | %s |\n",
              omp_get_num_procs(), o3d_team.Median(), o3d_team.Quantile(0.9),
              ratio(o3d_team.Median()).c_str());
  std::printf("| Open3D, 1 thread (decoded images) | %.2f | %.2f | %s |\n", o3d_one.Median(),
              o3d_one.Quantile(0.9), ratio(o3d_one.Median()).c_str());
#endif
  std::fflush(stdout);
}

void Run() {
  const std::vector<RealFrame> frames = LoadYcbvFrames(absl::GetFlag(FLAGS_ycbv));
  const int reps = absl::GetFlag(FLAGS_reps);
  const int laps = absl::GetFlag(FLAGS_laps);
  const size_t window = size_t(absl::GetFlag(FLAGS_window));
  ThreadPool pool(absl::GetFlag(FLAGS_worker_threads));
  // As MapService: the shared decoder threads that decode frames ahead of map workers.
  server::WorkQueue decoder({.capacity = 256, .threads = std::max(2, pool.workers())});
  server::WorkQueue runner({.capacity = 4});
  std::printf("ingest_bench: %zu ycbv frames %dx%d, %d reps, worker_threads %d\n", frames.size(),
              frames[0].depth.width, frames[0].depth.height, reps, pool.workers());
  const std::vector<std::string> sections = absl::StrSplit(absl::GetFlag(FLAGS_sections), ',');
  auto want = [&](const char* name) {
    return std::find(sections.begin(), sections.end(), name) != sections.end();
  };
  if (want("codecs")) PrintCodecCosts(frames, reps);
  if (want("png")) {
    std::vector<std::string> dirs =
        absl::StrSplit(absl::GetFlag(FLAGS_png_dirs), ',', absl::SkipEmpty());
    if (dirs.empty()) {
      const std::string scene = absl::GetFlag(FLAGS_ycbv) + "/test/000000/";
      dirs = {scene + "rgb", scene + "depth"};
    }
    PrintPngDecoders(dirs, reps);
  }

  const std::vector<Codec> codecs = {
      {"raw + raw RGB", v1::DEPTH_ENCODING_RAW_U16, v1::COLOR_ENCODING_RAW_RGB8},
      {"PNG16 + PNG", v1::DEPTH_ENCODING_PNG16, v1::COLOR_ENCODING_PNG},
      {"PNG16 + JPEG", v1::DEPTH_ENCODING_PNG16, v1::COLOR_ENCODING_JPEG},
      {"zstd + JPEG", v1::DEPTH_ENCODING_ZSTD, v1::COLOR_ENCODING_JPEG},
      {"RVL + PNG", v1::DEPTH_ENCODING_RVL, v1::COLOR_ENCODING_PNG},
      {"RVL + JPEG", v1::DEPTH_ENCODING_RVL, v1::COLOR_ENCODING_JPEG},
  };
  constexpr size_t kDefaultCodec = 3;  // zstd + JPEG, the client library's default
  std::vector<std::vector<std::shared_ptr<const v1::Frame>>> single, stream;
  for (const Codec& c : codecs) {
    single.push_back(Encode(frames, c, 1, 0));
    stream.push_back(Encode(frames, c, laps, 10.0));
  }
  std::vector<perception::RgbdFrame> decoded;
  for (const auto& f : single[0]) decoded.push_back(*server::DecodeFrame(*f));

  const std::vector<std::string> resolutions =
      absl::StrSplit(absl::GetFlag(FLAGS_resolutions), ',');
  for (const std::string& res_text : resolutions) {
    const double res = std::stod(res_text);
    const server::MapConfig config = Config(res);
    const server::LiveMap::Options map_options{
        .config = config, .pool = &pool, .decoder = &decoder};
    // The same map with frames decoded on its worker, one image after the other (the
    // ingestion path before issue 15's decode-ahead).
    const server::LiveMap::Options serial_options{.config = config, .pool = &pool};
#ifdef SKIMAP_BENCH_OPEN3D
    std::vector<Open3dFrame> o3d_frames;
    for (const RealFrame& f : frames) o3d_frames.push_back(ToOpen3d(f, 0, 5.0));
#endif
    if (want("fresh")) {
      std::vector<Samples> ours(codecs.size()), decode(codecs.size());
      Samples stage, apply, excluded, open3d, open3d_one;
      for (int r = 0; r < reps; ++r) {
        for (size_t i = 0; i < frames.size(); ++i) {
          for (size_t c = 0; c < codecs.size(); ++c) {
            {
              const Clock::time_point t0 = Clock::now();
              absl::StatusOr<perception::RgbdFrame> d = server::DecodeFrame(*single[c][i]);
              decode[c].Add(Ms(Clock::now() - t0));
              if (!d.ok()) Die(d.status().ToString());
            }
            server::LiveMap map("bench", map_options);
            std::promise<absl::StatusOr<v1::FrameAck>> done;
            const Clock::time_point t0 = Clock::now();
            map.SubmitFrame(single[c][i], [&](absl::StatusOr<v1::FrameAck> ack) {
              done.set_value(std::move(ack));
            });
            absl::StatusOr<v1::FrameAck> ack = done.get_future().get();
            ours[c].Add(Ms(Clock::now() - t0));
            if (!ack.ok()) Die(ack.status().ToString());
          }
          // On a thread of its own, as a map's worker (and Open3D likewise, below).
          runner.Run([&] {
            server::MapState state(config, &pool);
            auto stages = server::MakeFrameStages(config, Grid(config.resolution), &pool);
            const Clock::time_point t0 = Clock::now();
            size_t points = 0, voxels = 0;
            for (auto& s : stages) points += s->Stage(decoded[i], server::FrameStage::kAdd).points;
            const Clock::time_point t1 = Clock::now();
            for (auto& s : stages) voxels += s->Apply(&state).voxels_touched;
            const Clock::time_point t2 = Clock::now();
            if (points == 0 || voxels == 0) Die("a frame integrated nothing");
            if (r == 0 && i == 0) {
              std::fprintf(stderr, "frame 0 at %.0f cm: %zu points, %zu voxels\n", res * 100,
                           points, voxels);
            }
            stage.Add(Ms(t1 - t0));
            apply.Add(Ms(t2 - t1));
            excluded.Add(Ms(t2 - t0));
          });
#ifdef SKIMAP_BENCH_OPEN3D
          // Open3D's OpenMP team (as many threads as cores), and one thread: on a machine
          // loaded by other work a team's barriers can cost more than its parallelism gains.
          for (const int threads : {0, 1}) {
            runner.Run([&] {
              omp_set_num_threads(threads == 0 ? omp_get_num_procs() : threads);
              auto volume = NewVolume(res);
              const Clock::time_point t0 = Clock::now();
              volume->Integrate(*o3d_frames[i].rgbd, o3d_frames[i].intrinsic,
                                o3d_frames[i].extrinsic);
              (threads == 0 ? open3d : open3d_one).Add(Ms(Clock::now() - t0));
            });
          }
#endif
        }
      }
      // The peer's figure: the faster of its two thread settings.
      const double o3d_median = std::min(open3d.Median(), open3d_one.Median());
      auto ratio = [&](double v) {
        return o3d_median > 0 ? absl::StrFormat("%.2f", v / o3d_median) : std::string("-");
      };
      std::printf("\n### Per frame, new space, %.0f cm (median / p90 ms over %d samples)\n\n",
                  res * 100, reps * int(frames.size()));
      std::printf("| variant | server ms (median) | p90 | of which decode+validate | / Open3D |\n");
      std::printf("|---|---|---|---|---|\n");
      for (size_t c = 0; c < codecs.size(); ++c) {
        const double m = ours[c].Median();
        std::printf("| ours, %s, decode included | %.2f | %.2f | %.2f | %s |\n", codecs[c].name, m,
                    ours[c].Quantile(0.9), decode[c].Median(), ratio(m).c_str());
      }
      const double ex = excluded.Median();
      std::printf("| ours, decode excluded (Stage %.2f + Apply %.2f) | %.2f | %.2f | - | %s |\n",
                  stage.Median(), apply.Median(), ex, excluded.Quantile(0.9), ratio(ex).c_str());
      if (o3d_median > 0) {
        std::printf(
            "| Open3D ScalableTSDFVolume::Integrate (decoded images), %d OpenMP threads | "
            "%.2f | %.2f | - | %s |\n",
            PeerThreads(), open3d.Median(), open3d.Quantile(0.9), ratio(open3d.Median()).c_str());
        std::printf(
            "| Open3D ScalableTSDFVolume::Integrate (decoded images), 1 thread | %.2f | "
            "%.2f | - | %s |\n",
            open3d_one.Median(), open3d_one.Quantile(0.9), ratio(open3d_one.Median()).c_str());
      }
    }

    // 2b. Re-observed space: the same frames again into a map (a volume) that holds them
    // already, zstd + JPEG for ours (the client's default), team and one thread for Open3D.
    if (want("reobserved")) {
      Samples warm_ours, warm_o3d, warm_o3d_one;
      server::LiveMap map("bench", map_options);
      Stream(map, single[kDefaultCodec], window);
#ifdef SKIMAP_BENCH_OPEN3D
      std::unique_ptr<open3d::pipelines::integration::ScalableTSDFVolume> volumes[2];
      for (const int threads : {0, 1}) {
        runner.Run([&] {
          omp_set_num_threads(threads == 0 ? omp_get_num_procs() : threads);
          volumes[threads] = NewVolume(res);
          for (const Open3dFrame& f : o3d_frames) {
            volumes[threads]->Integrate(*f.rgbd, f.intrinsic, f.extrinsic);
          }
        });
      }
#endif
      uint64_t sequence = 1000;
      for (int r = 0; r < reps; ++r) {
        for (size_t i = 0; i < frames.size(); ++i) {
          auto again = std::make_shared<v1::Frame>(*single[kDefaultCodec][i]);
          again->set_sequence(++sequence);
          std::promise<absl::StatusOr<v1::FrameAck>> done;
          const Clock::time_point t0 = Clock::now();
          map.SubmitFrame(
              again, [&](absl::StatusOr<v1::FrameAck> ack) { done.set_value(std::move(ack)); });
          if (absl::StatusOr<v1::FrameAck> ack = done.get_future().get(); !ack.ok()) {
            Die(ack.status().ToString());
          }
          warm_ours.Add(Ms(Clock::now() - t0));
#ifdef SKIMAP_BENCH_OPEN3D
          for (const int threads : {0, 1}) {
            runner.Run([&] {
              omp_set_num_threads(threads == 0 ? omp_get_num_procs() : threads);
              const Clock::time_point t1 = Clock::now();
              volumes[threads]->Integrate(*o3d_frames[i].rgbd, o3d_frames[i].intrinsic,
                                          o3d_frames[i].extrinsic);
              (threads == 0 ? warm_o3d : warm_o3d_one).Add(Ms(Clock::now() - t1));
            });
          }
#endif
        }
      }
      const double peer = std::min(warm_o3d.Median(), warm_o3d_one.Median());
      std::printf(
          "\n### Per frame, re-observed space, %.0f cm (median / p90 ms over %d samples)"
          "\n\n| variant | ms (median) | p90 | / Open3D |\n|---|---|---|---|\n",
          res * 100, reps * int(frames.size()));
      std::printf("| ours, zstd + JPEG, decode included | %.2f | %.2f | %s |\n", warm_ours.Median(),
                  warm_ours.Quantile(0.9),
                  peer > 0 ? absl::StrFormat("%.2f", warm_ours.Median() / peer).c_str() : "-");
      if (peer > 0) {
        std::printf("| Open3D, %d OpenMP threads (decoded images) | %.2f | %.2f | %.2f |\n",
                    PeerThreads(), warm_o3d.Median(), warm_o3d.Quantile(0.9),
                    warm_o3d.Median() / peer);
        std::printf("| Open3D, 1 thread (decoded images) | %.2f | %.2f | %.2f |\n",
                    warm_o3d_one.Median(), warm_o3d_one.Quantile(0.9),
                    warm_o3d_one.Median() / peer);
      }
    }

    if (want("running")) RunningMap(frames, config, map_options, pool, runner, reps);
    if (want("profile")) {
      // Not in the default set: the decode-excluded stages alone, reps x 100 frames of new
      // space into one running map, for a profiler (perf record ... --sections=profile).
      std::vector<perception::RgbdFrame> moved;
      for (int k = 0; k < 100; ++k) {
        moved.push_back(decoded[size_t(k) % decoded.size()]);
        moved.back().pose.translation.x() += 10.0 * k;
      }
      runner.Run([&] {
        server::MapState state(config, &pool);
        auto stages = server::MakeFrameStages(config, Grid(config.resolution), &pool);
        const Clock::time_point t0 = Clock::now();
        for (int r = 0; r < reps; ++r) {
          for (perception::RgbdFrame& f : moved) {
            f.pose.translation.z() += 10.0;
            for (auto& st : stages) st->Stage(f, server::FrameStage::kAdd);
            for (auto& st : stages) st->Apply(&state);
          }
        }
        std::printf("profile: %.3f ms per frame\n", Ms(Clock::now() - t0) / (reps * 100.0));
      });
    }
    if (!want("stream")) continue;

    // 3. Throughput: a stream of new space.
    std::printf("\n### Stream, new space, %.0f cm: %d frames, %zu in flight, in-process\n\n",
                res * 100, laps * int(frames.size()), window);
    std::printf("| variant | frames/s | / Open3D |\n|---|---|---|\n");
    double o3d_fps = 0;
#ifdef SKIMAP_BENCH_OPEN3D
    {
      std::vector<Open3dFrame> moved;
      for (int lap = 0; lap < laps; ++lap) {
        for (const RealFrame& f : frames)
          moved.push_back(ToOpen3d(f, double(moved.size()) * 10, 5.0));
      }
      for (const int threads : {0, 1}) {
        runner.Run([&] {
          omp_set_num_threads(threads == 0 ? omp_get_num_procs() : threads);
          auto volume = NewVolume(res);
          const Clock::time_point t0 = Clock::now();
          for (const Open3dFrame& f : moved) volume->Integrate(*f.rgbd, f.intrinsic, f.extrinsic);
          o3d_fps = std::max(o3d_fps, double(moved.size()) / (Ms(Clock::now() - t0) / 1000));
        });
      }
    }
#endif
    for (size_t c = 0; c < codecs.size(); ++c) {
      for (const bool ahead : {true, false}) {
        server::LiveMap map("bench", ahead ? map_options : serial_options);
        const Clock::time_point t0 = Clock::now();
        Stream(map, stream[c], window);
        const double fps = double(stream[c].size()) / (Ms(Clock::now() - t0) / 1000);
        std::printf("| ours, %s, %s | %.1f | %s |\n", codecs[c].name,
                    ahead ? "decode ahead (skimapd)" : "decode on the worker", fps,
                    o3d_fps > 0 ? absl::StrFormat("%.2f", fps / o3d_fps).c_str() : "-");
      }
    }
    if (o3d_fps > 0) {
      std::printf("| Open3D (decoded images), the faster of %d threads and 1 | %.1f | 1 |\n",
                  PeerThreads(), o3d_fps);
    }
    std::fflush(stdout);
  }
}

}  // namespace
}  // namespace skimap::bench

int main(int argc, char** argv) {
#ifdef SKIMAP_BENCH_OPEN3D
  // libgomp reads its wait policy when it loads: by default Open3D's idle OpenMP threads
  // spin after each Integrate and take a core from whatever is timed next (ours or its own
  // one-thread run). Passive waiting, set by re-running this program, keeps the samples
  // apart; the one-thread runs have no team to wake.
  if (std::getenv("OMP_WAIT_POLICY") == nullptr) {
    setenv("OMP_WAIT_POLICY", "PASSIVE", 1);
    execv("/proc/self/exe", argv);
  }
#endif
  // skimapd's allocator settings, for both sides: Open3D's 196 kB volume units then come
  // from the heap too instead of a fresh mmap each (without them its running-volume
  // figures depend on which run freed memory first).
  skimap::server::TuneMallocForServer();
  absl::ParseCommandLine(argc, argv);
  skimap::bench::Run();
  return 0;
}
