// Analytic test scene for the server tests: a floor plane z = 0 and one box standing on
// it, seen by a pinhole camera. Depth is ray-cast exactly (1 mm units), so tests can check
// the map against the geometry itself, not against another run of the same code.
#ifndef TESTS_COMMON_SYNTHETIC_SCENE_H_
#define TESTS_COMMON_SYNTHETIC_SCENE_H_

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "skimap/v1/frames.pb.h"

namespace skimap::testing {

struct SceneBox {
  Eigen::Vector3d min{0.3, -0.2, 0.0}, max{0.7, 0.2, 0.5};
};

struct SyntheticCamera {
  int width = 160, height = 120;
  double fx = 120, fy = 120, cx = 79.5, cy = 59.5;
};

// Camera at `position` looking along `forward` (world z up), as a world <- camera pose.
inline Eigen::Isometry3d LookingAlong(const Eigen::Vector3d& position, Eigen::Vector3d forward) {
  forward.normalize();
  const Eigen::Vector3d right = forward.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d down = forward.cross(right);
  Eigen::Matrix3d r;
  r << right, down, forward;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = r;
  pose.translation() = position;
  return pose;
}

// The default view: 1.5 m up, 1.5 m behind the box's front, 45 degrees down.
inline Eigen::Isometry3d DefaultView() { return LookingAlong({-1.5, 0, 1.5}, {1, 0, -1}); }

// Frame i's camera on an orbit around the box whose angle, radius and height never repeat,
// always looking at the box (so every frame hits the box and the floor): the fleet, crash
// and fleet_bench streams.
inline Eigen::Isometry3d OrbitView(uint64_t i) {
  const double angle = 0.37 * double(i);
  const double radius = 1.6 + 0.3 * std::sin(0.13 * double(i));
  const double height = 1.1 + 0.4 * std::sin(0.23 * double(i) + 1.0);
  const Eigen::Vector3d target(0.5, 0.0, 0.25);
  const Eigen::Vector3d position(target.x() + radius * std::cos(angle),
                                 target.y() + radius * std::sin(angle), height);
  return LookingAlong(position, target - position);
}

// Ray parameter of the first hit of origin + t*dir with the floor or the box (t > 0), or
// infinity.
inline double CastRay(const Eigen::Vector3d& o, const Eigen::Vector3d& d, const SceneBox& box) {
  double best = std::numeric_limits<double>::infinity();
  if (d.z() < 0) best = -o.z() / d.z();
  double t0 = 0, t1 = best;
  for (int a = 0; a < 3; ++a) {
    if (std::abs(d[a]) < 1e-12) {
      if (o[a] < box.min[a] || o[a] > box.max[a]) return best;
      continue;
    }
    double ta = (box.min[a] - o[a]) / d[a], tb = (box.max[a] - o[a]) / d[a];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
  }
  return t0 <= t1 ? std::min(best, t0) : best;
}

// Depth image in millimetres (0 = no hit) of the scene seen from `pose`.
inline std::vector<uint16_t> RenderDepth(const Eigen::Isometry3d& pose, const SyntheticCamera& c,
                                         const SceneBox& box = {}) {
  std::vector<uint16_t> depth(size_t(c.width) * c.height, 0);
  for (int v = 0; v < c.height; ++v) {
    for (int u = 0; u < c.width; ++u) {
      const Eigen::Vector3d ray_cam((u - c.cx) / c.fx, (v - c.cy) / c.fy, 1.0);
      const double t = CastRay(pose.translation(), pose.linear() * ray_cam, box);
      // With ray_cam.z = 1, t is the depth along the optical axis.
      if (std::isfinite(t) && t < 60.0)
        depth[size_t(v) * c.width + u] = uint16_t(std::lround(t * 1000));
    }
  }
  return depth;
}

inline void SetPose(const Eigen::Isometry3d& pose, v1::Pose* out) {
  const Eigen::Quaterniond q(pose.linear());
  out->mutable_rotation()->set_w(q.w());
  out->mutable_rotation()->set_x(q.x());
  out->mutable_rotation()->set_y(q.y());
  out->mutable_rotation()->set_z(q.z());
  out->mutable_translation()->set_x(pose.translation().x());
  out->mutable_translation()->set_y(pose.translation().y());
  out->mutable_translation()->set_z(pose.translation().z());
}

// A RAW_U16 frame (no colour) of the scene from `pose`.
inline v1::Frame MakeFrame(const std::string& map, uint64_t sequence, const Eigen::Isometry3d& pose,
                           const SyntheticCamera& c = {}, const SceneBox& box = {}) {
  v1::Frame f;
  f.set_map(map);
  f.set_sequence(sequence);
  SetPose(pose, f.mutable_pose());
  auto* k = f.mutable_intrinsics();
  k->set_fx(c.fx);
  k->set_fy(c.fy);
  k->set_cx(c.cx);
  k->set_cy(c.cy);
  k->set_width(c.width);
  k->set_height(c.height);
  const std::vector<uint16_t> depth = RenderDepth(pose, c, box);
  std::string bytes(depth.size() * 2, '\0');
  for (size_t i = 0; i < depth.size(); ++i) {
    bytes[2 * i] = char(depth[i] & 0xff);
    bytes[2 * i + 1] = char(depth[i] >> 8);
  }
  f.set_depth_encoding(v1::DEPTH_ENCODING_RAW_U16);
  f.set_depth(bytes);
  f.set_depth_scale(0.001);
  return f;
}

}  // namespace skimap::testing

#endif  // TESTS_COMMON_SYNTHETIC_SCENE_H_
