// Parallel sequence rendering and annotation. See sequence.h for the contract.
#include "sim/sequence.h"

#include <atomic>
#include <chrono>
#include <cmath>
#include <mutex>
#include <opencv2/imgproc.hpp>
#include <random>
#include <thread>

#include "absl/strings/str_cat.h"
#include "codec/image_files.h"
#include "dataset/writer.h"

namespace skimap::sim {
namespace {

using Clock = std::chrono::steady_clock;

absl::Status Write(const std::string& path, const cv::Mat& img) {
  if (!perception::WriteImageFile(path, img, {.png_compression = 3}).ok()) {
    return absl::InternalError(absl::StrCat(path, ": cannot write image"));
  }
  return absl::OkStatus();
}

Eigen::Isometry3f Interpolate(const Eigen::Isometry3f& a, const Eigen::Isometry3f& b, float t) {
  Eigen::Isometry3f T = Eigen::Isometry3f::Identity();
  T.linear() =
      Eigen::Quaternionf(a.linear()).slerp(t, Eigen::Quaternionf(b.linear())).toRotationMatrix();
  T.translation() = (1 - t) * a.translation() + t * b.translation();
  return T;
}

// BOP bbox [x, y, w, h] with w = x_max - x_min (bop_toolkit calc_2d_bbox); -1s if empty.
std::array<int, 4> BBox(const cv::Mat& mask) {
  const cv::Rect r = cv::boundingRect(mask);
  if (r.area() == 0) return {-1, -1, -1, -1};
  return {r.x, r.y, r.width - 1, r.height - 1};
}

struct Worker {
  RenderOutput out, blur;
  cv::Mat acc;
};

// Renders, annotates and writes frame i. Returns the frame metadata.
absl::StatusOr<dataset::Frame> DoFrame(const SequenceSpec& s, int i, Worker& w,
                                       double* render_seconds) {
  const auto t0 = Clock::now();
  const dataset::Intrinsics& K = s.camera.K;
  const Eigen::Isometry3f& T = s.poses[i];
  Render(s.instances, K, T, s.light, &w.out);
  if (s.motion_blur >= 2 && i > 0) {  // shutter open for the second half of the interval
    w.out.bgr.convertTo(w.acc, CV_32FC3);
    for (int k = 0; k + 1 < s.motion_blur; ++k) {
      const float t = 0.5f + 0.5f * k / (s.motion_blur - 1);
      Render(s.instances, K, Interpolate(s.poses[i - 1], T, t), s.light, &w.blur);
      cv::accumulate(w.blur.bgr, w.acc);
    }
    w.acc.convertTo(w.out.bgr, CV_8UC3, 1.0 / s.motion_blur);
  }
  std::mt19937_64 rng(s.seed * 0x9E3779B97F4A7C15ull + static_cast<uint64_t>(i) * 7919 + 1);
  if (s.exposure_drift > 0 || s.exposure_jitter > 0) {
    const double phase = static_cast<double>(s.seed % 6283) / 1000.0;
    const double jitter =
        s.exposure_jitter * (2.0 * static_cast<double>(rng() >> 11) / 9007199254740992.0 - 1);
    const double gain =
        1 + s.exposure_drift * std::sin(2 * M_PI * (i / s.fps) / 5.0 + phase) + jitter;
    w.out.bgr.convertTo(w.out.bgr, -1, gain);
  }
  AddColourNoise(w.out.bgr, s.colour_noise, rng);
  cv::Mat depth = SimulateDepth(w.out.depth, w.out.incidence, static_cast<float>(K.fx),
                                s.camera.depth_scale, s.noise, rng);
  *render_seconds += std::chrono::duration<double>(Clock::now() - t0).count();

  dataset::Frame f;
  f.id = i;
  f.timestamp = i / s.fps;
  f.K = K;
  f.depth_scale = s.camera.depth_scale;
  f.has_pose = true;
  f.T_wc = T.cast<double>();
  if (auto st = Write(dataset::BopRgbPath(s.dir, i), w.out.bgr); !st.ok()) return st;
  if (auto st = Write(dataset::BopDepthPath(s.dir, i), depth); !st.ok()) return st;
  const Eigen::Isometry3f T_cw = T.inverse();
  for (size_t g = 0; g < s.annotated.size(); ++g) {
    const Instance& inst = s.instances[s.annotated[g]];
    const cv::Mat mask = w.out.ids == inst.id;
    const cv::Mat cover = RenderCoverage(inst, K, T);
    dataset::ObjectAnnotation a;
    a.obj_id = s.obj_ids[g];
    a.T_m2c = (T_cw * inst.T_wm).cast<double>();
    a.px_count_visib = cv::countNonZero(mask);
    a.px_count_valid = cv::countNonZero(mask & (depth > 0));
    a.px_count_all = cv::countNonZero(cover);
    a.visib_fract = a.px_count_all > 0 ? static_cast<double>(a.px_count_visib) / a.px_count_all : 0;
    a.bbox_visib = BBox(mask);
    a.bbox_obj = BBox(cover);
    a.mask_visib_path = dataset::BopMaskVisibPath(s.dir, i, static_cast<int>(g));
    if (auto st = Write(a.mask_visib_path, mask); !st.ok()) return st;
    f.objects.push_back(a);
  }
  return f;
}

}  // namespace

absl::StatusOr<SequenceStats> RenderSequence(const SequenceSpec& s, int threads,
                                             std::ostream* progress) {
  const auto start = Clock::now();
  dataset::BopSceneWriter writer(s.dir);
  if (absl::Status st = writer.Create(); !st.ok()) return st;
  const int n = static_cast<int>(s.poses.size());
  std::vector<dataset::Frame> frames(n);
  std::atomic<int> next{0}, done{0};
  std::mutex mu;
  absl::Status error;
  double render_seconds = 0;
  auto work = [&] {
    Worker w;
    double mine = 0;
    for (int i = next++; i < n; i = next++) {
      absl::StatusOr<dataset::Frame> f = DoFrame(s, i, w, &mine);
      std::lock_guard<std::mutex> lock(mu);
      if (!f.ok()) {
        if (error.ok()) error = f.status();
        next = n;
        break;
      }
      frames[i] = std::move(*f);
      const int d = ++done;
      if (progress && (d % 50 == 0 || d == n)) {
        const double el = std::chrono::duration<double>(Clock::now() - start).count();
        *progress << "  " << s.label << ": " << d << "/" << n << " frames, " << el << " s\n"
                  << std::flush;
      }
    }
    std::lock_guard<std::mutex> lock(mu);
    render_seconds += mine;
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < std::max(1, threads); ++t) pool.emplace_back(work);
  work();
  for (std::thread& t : pool) t.join();
  if (!error.ok()) return error;
  for (const dataset::Frame& f : frames) writer.AddFrame(f);
  if (absl::Status st = writer.Finish(); !st.ok()) return st;
  SequenceStats stats;
  stats.frames = n;
  stats.render_seconds = render_seconds;
  stats.wall_seconds = std::chrono::duration<double>(Clock::now() - start).count();
  return stats;
}

}  // namespace skimap::sim
