#include "bench/bench_data.h"

#include <malloc.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <numbers>
#include <random>

#include "nlohmann/json.hpp"
#include "opencv2/imgcodecs.hpp"

namespace skimap::bench {
namespace {

struct Box {
  double lo[3], hi[3];
};

// Room interior (walls, floor, ceiling) and the obstacles inside it.
constexpr Box kRoom{{0, 0, 0}, {8, 9, 2.8}};
constexpr Box kObstacles[] = {
    {{5.0, 3.6, 0.72}, {6.4, 5.4, 0.76}},   // table top
    {{5.0, 3.6, 0.0}, {5.05, 3.65, 0.72}},  // table legs
    {{6.35, 3.6, 0.0}, {6.4, 3.65, 0.72}},
    {{5.0, 5.35, 0.0}, {5.05, 5.4, 0.72}},
    {{6.35, 5.35, 0.0}, {6.4, 5.4, 0.72}},
    {{5.3, 4.0, 0.76}, {5.6, 4.3, 1.0}},  // boxes on the table
    {{5.9, 4.6, 0.76}, {6.2, 5.0, 0.95}},
    {{6.5, 2.0, 0.0}, {7.1, 2.6, 0.5}},  // boxes on the floor
    {{6.8, 6.0, 0.0}, {7.6, 7.0, 0.9}},
    {{1.0, 7.5, 0.0}, {1.6, 8.3, 0.6}},
    {{7.5, 3.5, 0.0}, {8.0, 5.5, 1.8}},  // cabinet against the far wall
};

// Distance along the ray o + t*d to the nearest surface of the room.
double CastRay(const double o[3], const double d[3]) {
  double best = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a) {  // inside the room: exit through one wall / floor / ceiling
    if (d[a] > 1e-12) best = std::min(best, (kRoom.hi[a] - o[a]) / d[a]);
    if (d[a] < -1e-12) best = std::min(best, (kRoom.lo[a] - o[a]) / d[a]);
  }
  for (const Box& b : kObstacles) {  // slab test, entry point only
    double t0 = 0, t1 = best;
    for (int a = 0; a < 3 && t0 <= t1; ++a) {
      if (std::abs(d[a]) < 1e-12) {
        if (o[a] < b.lo[a] || o[a] > b.hi[a]) t0 = t1 + 1;
        continue;
      }
      double ta = (b.lo[a] - o[a]) / d[a], tb = (b.hi[a] - o[a]) / d[a];
      if (ta > tb) std::swap(ta, tb);
      t0 = std::max(t0, ta);
      t1 = std::min(t1, tb);
    }
    if (t0 <= t1 && t0 > 0) best = std::min(best, t0);
  }
  return best;
}

PointF Transform(const CameraPose& p, double x, double y, double z) {
  return {static_cast<float>(p.r[0] * x + p.r[1] * y + p.r[2] * z + p.t[0]),
          static_cast<float>(p.r[3] * x + p.r[4] * y + p.r[5] * z + p.t[1]),
          static_cast<float>(p.r[6] * x + p.r[7] * y + p.r[8] * z + p.t[2])};
}

std::string YcbvDir() {
  if (const char* env = std::getenv("SKIMAP_YCBV_DIR")) return env;
  return SKIMAP_BENCH_YCBV_DIR;
}

// Loads the frames or sets `error`.
std::vector<Cloud> LoadYcbv(std::string* error, std::vector<PointF>* origins) {
  const std::string dir = YcbvDir() + "/test/000000";
  std::ifstream in(dir + "/scene_camera.json");
  if (!in) {
    *error = "cannot open " + dir + "/scene_camera.json";
    return {};
  }
  const nlohmann::json cameras = nlohmann::json::parse(in, nullptr, /*allow_exceptions=*/false);
  if (cameras.is_discarded()) {
    *error = "bad JSON in scene_camera.json";
    return {};
  }
  std::vector<Cloud> frames;
  for (int id = 0; cameras.contains(std::to_string(id)); ++id) {
    const nlohmann::json& cam = cameras[std::to_string(id)];
    char name[32];
    std::snprintf(name, sizeof(name), "/depth/%06d.png", id);
    const cv::Mat depth = cv::imread(dir + name, cv::IMREAD_ANYDEPTH);
    if (depth.empty() || depth.type() != CV_16UC1) {
      *error = std::string("cannot read 16-bit depth ") + dir + name;
      return {};
    }
    const auto k = cam["cam_K"].get<std::vector<double>>();
    const auto r = cam["cam_R_w2c"].get<std::vector<double>>();    // row-major
    const auto t = cam["cam_t_w2c"].get<std::vector<double>>();    // mm
    const double scale = cam["depth_scale"].get<double>() * 1e-3;  // raw -> metres
    // world = R^T (cam - t).
    CameraPose pose;
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) pose.r[3 * i + j] = r[3 * j + i];
    }
    for (int i = 0; i < 3; ++i) {
      pose.t[i] =
          -(pose.r[3 * i] * t[0] + pose.r[3 * i + 1] * t[1] + pose.r[3 * i + 2] * t[2]) * 1e-3;
    }
    origins->push_back(Transform(pose, 0, 0, 0));
    Cloud cloud;
    cloud.reserve(depth.total());
    for (int v = 0; v < depth.rows; ++v) {
      const uint16_t* row = depth.ptr<uint16_t>(v);
      for (int u = 0; u < depth.cols; ++u) {
        if (row[u] == 0) continue;
        const double z = row[u] * scale;
        cloud.push_back(Transform(pose, (u - k[2]) / k[0] * z, (v - k[5]) / k[4] * z, z));
      }
    }
    frames.push_back(std::move(cloud));
  }
  if (frames.empty()) *error = "no frames in scene_camera.json";
  return frames;
}

struct YcbvData {
  std::string error;
  std::vector<PointF> origins;
  std::vector<Cloud> frames = LoadYcbv(&error, &origins);
};
const YcbvData& Ycbv() {
  static const YcbvData data;
  return data;
}

}  // namespace

CameraPose RoomCameraPose(double x, double y, double yaw_deg, double pitch_deg) {
  const double yaw = yaw_deg * std::numbers::pi / 180, pitch = pitch_deg * std::numbers::pi / 180;
  const double f[3] = {std::cos(pitch) * std::cos(yaw), std::cos(pitch) * std::sin(yaw),
                       -std::sin(pitch)};
  const double r[3] = {std::sin(yaw), -std::cos(yaw), 0};
  const double d[3] = {f[1] * r[2] - f[2] * r[1], f[2] * r[0] - f[0] * r[2],
                       f[0] * r[1] - f[1] * r[0]};  // down = forward x right
  CameraPose pose;
  for (int i = 0; i < 3; ++i) {  // columns: camera x, y, z axes in the world
    pose.r[3 * i] = r[i];
    pose.r[3 * i + 1] = d[i];
    pose.r[3 * i + 2] = f[i];
  }
  pose.t[0] = x, pose.t[1] = y, pose.t[2] = 1.3;
  return pose;
}

Cloud RenderRoomFrame(const CameraPose& pose, uint32_t seed) {
  constexpr int kWidth = 640, kHeight = 480;
  constexpr double kF = 525, kCx = 319.5, kCy = 239.5;
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0, 1);
  Cloud cloud;
  cloud.reserve(kWidth * kHeight);
  for (int v = 0; v < kHeight; ++v) {
    for (int u = 0; u < kWidth; ++u) {
      const double c[3] = {(u - kCx) / kF, (v - kCy) / kF, 1};  // ray with camera z = 1
      double d[3];
      for (int i = 0; i < 3; ++i)
        d[i] = pose.r[3 * i] * c[0] + pose.r[3 * i + 1] * c[1] + pose.r[3 * i + 2] * c[2];
      const double z = CastRay(pose.t, d);  // camera-frame depth, since c.z = 1
      if (!std::isfinite(z) || z > 8.0) continue;
      const double sigma = 0.0012 + 0.0019 * (z - 0.4) * (z - 0.4);
      const double zn = z + sigma * noise(rng);
      cloud.push_back(Transform(pose, c[0] * zn, c[1] * zn, zn));
    }
  }
  return cloud;
}

const Cloud& RoomFrame() {
  static const Cloud frame = RenderRoomFrame(RoomCameraPose(3.5, 4.5, 0, 15), 1);
  return frame;
}

PointF RoomOrigin() { return {3.5f, 4.5f, 1.3f}; }

const std::vector<Cloud>& RoomSweep() {
  static const std::vector<Cloud> frames = [] {
    std::vector<Cloud> out;
    for (int i = 0; i < kRoomSweepFrames; ++i) {
      const double x = 2.0 + 4.0 * ((i * 5) % kRoomSweepFrames) / kRoomSweepFrames;
      const double y = 2.0 + 5.0 * ((i * 3) % kRoomSweepFrames) / kRoomSweepFrames;
      const double yaw = i * 360.0 / kRoomSweepFrames;
      const double pitch = 10 + 20 * (i % 3) / 2.0;
      out.push_back(RenderRoomFrame(RoomCameraPose(x, y, yaw, pitch), 100 + i));
    }
    return out;
  }();
  return frames;
}

const std::vector<Cloud>& YcbvFrames() { return Ycbv().frames; }
const std::string& YcbvError() { return Ycbv().error; }
const std::vector<PointF>& YcbvOrigins() { return Ycbv().origins; }

const Cloud& UniformPoints() {
  static const Cloud points = [] {
    std::mt19937 rng(42);
    std::uniform_real_distribution<float> u(0.0f, static_cast<float>(kUniformSide));
    Cloud out(1'000'000);
    for (PointF& p : out) p = {u(rng), u(rng), u(rng)};
    return out;
  }();
  return points;
}

const Cloud& BigMapPoints() {
  static const Cloud points = [] {
    constexpr int kSide = 2800;  // 28 m at 1 cm
    constexpr int kWallTop = 300;
    Cloud out;
    out.reserve(14'000'000);
    auto add = [&](int x, int y, int z) {
      out.push_back({(x + 0.5f) * 0.01f, (y + 0.5f) * 0.01f, (z + 0.5f) * 0.01f});
    };
    for (int x = 0; x < kSide; ++x) {
      for (int y = 0; y < kSide; ++y) add(x, y, 0);
    }
    for (int z = 1; z < kWallTop; ++z) {
      for (int i = 0; i < kSide; ++i) {
        add(i, 0, z), add(i, kSide - 1, z);
        if (i > 0 && i < kSide - 1) add(0, i, z), add(kSide - 1, i, z);
      }
    }
    for (int cx = 0; cx < 6; ++cx) {  // 6 x 6 crates, 1 m cubes on a 4 m pitch
      for (int cy = 0; cy < 6; ++cy) {
        const int x0 = 200 + 400 * cx, y0 = 200 + 400 * cy, x1 = x0 + 99, y1 = y0 + 99;
        for (int x = x0; x <= x1; ++x) {
          for (int y = y0; y <= y1; ++y) add(x, y, 100);  // lid
        }
        for (int z = 1; z < 100; ++z) {
          for (int i = 0; i < 100; ++i) {
            add(x0 + i, y0, z), add(x0 + i, y1, z);
            if (i > 0 && i < 99) add(x0, y0 + i, z), add(x1, y0 + i, z);
          }
        }
      }
    }
    return out;
  }();
  return points;
}

Cloud QueryCenters(const Cloud& cloud, size_t n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<size_t> pick(0, cloud.size() - 1);
  Cloud out(n);
  for (PointF& p : out) p = cloud[pick(rng)];
  return out;
}

size_t HeapBytesInUse() {
  const struct mallinfo2 m = mallinfo2();
  return m.uordblks + m.hblkhd;
}

}  // namespace skimap::bench
