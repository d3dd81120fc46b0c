// TUM RGB-D reader and LoadSequence. See reader.h for the contract.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <sstream>

#include "absl/strings/str_cat.h"
#include "dataset/json_util.h"
#include "dataset/reader.h"

namespace skimap::dataset {
namespace {

namespace fs = std::filesystem;

struct Stamped {
  double t = 0;
  std::string path;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
};

// Parses "timestamp value..." lines; `fields` values after the timestamp are required.
absl::StatusOr<std::vector<Stamped>> ReadList(const std::string& path, bool is_pose) {
  absl::StatusOr<std::string> text = internal::ReadTextFile(path);
  if (!text.ok()) return text.status();
  std::vector<Stamped> out;
  std::istringstream lines(*text);
  std::string line;
  for (int n = 1; std::getline(lines, line); ++n) {
    if (line.empty() || line[0] == '#' || line.find_first_not_of(" \t\r") == std::string::npos) {
      continue;
    }
    std::istringstream ls(line);
    Stamped s;
    bool ok = static_cast<bool>(ls >> s.t);
    if (is_pose) {
      double v[7];
      for (double& x : v) ok = ok && static_cast<bool>(ls >> x);
      if (ok) {
        Eigen::Quaterniond q(v[6], v[3], v[4], v[5]);
        ok = q.norm() > 0.5;
        s.pose.linear() = q.normalized().toRotationMatrix();
        s.pose.translation() = Eigen::Vector3d(v[0], v[1], v[2]);
      }
    } else {
      ok = ok && static_cast<bool>(ls >> s.path);
      if (ok && fs::path(s.path).is_relative())
        s.path = (fs::path(path).parent_path() / s.path).string();
    }
    if (!ok) {
      return absl::InvalidArgumentError(absl::StrCat(path, ":", n, ": malformed line"));
    }
    out.push_back(std::move(s));
  }
  std::stable_sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.t < b.t; });
  return out;
}

// Index of the entry nearest to t within max_dt, or -1.
int Nearest(const std::vector<Stamped>& v, double t, double max_dt) {
  auto it =
      std::lower_bound(v.begin(), v.end(), t, [](const Stamped& s, double x) { return s.t < x; });
  int best = -1;
  double best_dt = max_dt;
  for (auto c : {it, it == v.begin() ? v.end() : it - 1}) {
    if (c == v.end()) continue;
    const double dt = std::abs(c->t - t);
    if (dt <= best_dt) {
      best_dt = dt;
      best = static_cast<int>(c - v.begin());
    }
  }
  return best;
}

}  // namespace

Intrinsics TumDefaultIntrinsics() { return {525.0, 525.0, 319.5, 239.5, 640, 480}; }

absl::StatusOr<Sequence> LoadTumSequence(const std::string& dir, const TumOptions& options) {
  auto rgb = ReadList(dir + "/rgb.txt", false);
  if (!rgb.ok()) return rgb.status();
  auto depth = ReadList(dir + "/depth.txt", false);
  if (!depth.ok()) return depth.status();
  std::vector<Stamped> gt;
  if (fs::exists(dir + "/groundtruth.txt")) {
    auto g = ReadList(dir + "/groundtruth.txt", true);
    if (!g.ok()) return g.status();
    gt = std::move(*g);
  }
  Sequence seq;
  seq.dir = dir;
  for (size_t i = 0; i < rgb->size(); ++i) {
    const Stamped& r = (*rgb)[i];
    const int d = Nearest(*depth, r.t, options.max_dt);
    if (d < 0) continue;
    Frame f;
    f.id = static_cast<int>(i);
    f.timestamp = r.t;
    f.K = options.K;
    f.depth_scale = options.depth_scale;
    f.rgb_path = r.path;
    f.depth_path = (*depth)[d].path;
    const int p = Nearest(gt, r.t, options.max_dt);
    if (p >= 0) {
      f.has_pose = true;
      f.T_wc = gt[p].pose;
    }
    seq.frames.push_back(std::move(f));
  }
  if (seq.frames.empty()) {
    return absl::InvalidArgumentError(
        absl::StrCat(dir, ": no rgb image has a depth image within ", options.max_dt, " s"));
  }
  return seq;
}

absl::StatusOr<Sequence> LoadSequence(const std::string& dir) {
  if (fs::exists(dir + "/scene_camera.json")) return LoadBopScene(dir);
  if (fs::exists(dir + "/rgb.txt")) return LoadTumSequence(dir);
  return absl::NotFoundError(
      absl::StrCat(dir, ": neither a BOP scene (scene_camera.json) nor TUM (rgb.txt)"));
}

}  // namespace skimap::dataset
