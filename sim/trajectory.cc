// Camera trajectories. See trajectory.h for the contract.
#include "sim/trajectory.h"

#include <algorithm>
#include <cmath>
#include <random>

#include "absl/strings/str_cat.h"

namespace skimap::sim {
namespace {

using Eigen::Vector2f;
using Eigen::Vector3f;
constexpr float kPi = 3.14159265f;

// Smooth pseudo-random tremor: a sum of sines with seeded phases.
struct Tremor {
  explicit Tremor(uint64_t seed) {
    std::mt19937_64 rng(seed);
    for (float& p : phase) p = static_cast<float>(rng() % 6283) / 1000.f;
  }
  // Offset in [-1, 1] for channel c at time t.
  float At(int c, float t) const {
    return 0.6f * std::sin(2.1f * t + phase[2 * c]) + 0.4f * std::sin(5.3f * t + phase[2 * c + 1]);
  }
  float phase[12];
};

Eigen::Isometry3f Perturb(Eigen::Isometry3f T, const Tremor& tr, float t, float pos, float ang) {
  T.translation() += pos * Vector3f(tr.At(0, t), tr.At(1, t), tr.At(2, t));
  const Eigen::Matrix3f R = (Eigen::AngleAxisf(ang * tr.At(3, t), Vector3f::UnitX()) *
                             Eigen::AngleAxisf(ang * tr.At(4, t), Vector3f::UnitY()) *
                             Eigen::AngleAxisf(ang * tr.At(5, t), Vector3f::UnitZ()))
                                .toRotationMatrix();
  T.linear() = T.linear() * R;
  return T;
}

}  // namespace

absl::StatusOr<TrajectoryKind> ParseTrajectoryKind(const std::string& name) {
  if (name == "orbit") return TrajectoryKind::kOrbit;
  if (name == "sweep") return TrajectoryKind::kSweep;
  if (name == "robot") return TrajectoryKind::kRobot;
  if (name == "tour") return TrajectoryKind::kTour;
  if (name == "patrol") return TrajectoryKind::kPatrol;
  return absl::InvalidArgumentError(
      absl::StrCat("unknown trajectory \"", name, "\" (orbit, sweep, robot, tour, patrol)"));
}

const char* TrajectoryKindName(TrajectoryKind kind) {
  switch (kind) {
    case TrajectoryKind::kOrbit:
      return "orbit";
    case TrajectoryKind::kSweep:
      return "sweep";
    case TrajectoryKind::kTour:
      return "tour";
    case TrajectoryKind::kPatrol:
      return "patrol";
    default:
      return "robot";
  }
}

Eigen::Isometry3f LookAt(const Vector3f& eye, const Vector3f& target) {
  const Vector3f z = (target - eye).normalized();
  const Vector3f x = z.cross(Vector3f::UnitZ()).normalized();
  const Vector3f y = z.cross(x);
  Eigen::Isometry3f T = Eigen::Isometry3f::Identity();
  T.linear().col(0) = x;
  T.linear().col(1) = y;
  T.linear().col(2) = z;
  T.translation() = eye;
  return T;
}

namespace {

// The tour (see the header): eye and look-at target of frame i of n.
void TourAt(const SceneLayout& scene, int i, int n, Vector3f* eye, Vector3f* target) {
  std::vector<Vector3f> objects;
  for (const Placement& p : scene.objects) objects.push_back(p.T_wm.translation());
  std::sort(objects.begin(), objects.end(), [](const Vector3f& a, const Vector3f& b) {
    return std::atan2(a.y(), a.x()) < std::atan2(b.y(), b.x());
  });
  const float half_w = scene.spec.width / 2 - 0.3f, half_d = scene.spec.depth / 2 - 0.3f;
  // The arc around object k at phase u in [0, 1].
  auto view = [&](size_t k, float u, Vector3f* e, Vector3f* t) {
    const Vector3f& obj = objects[k];
    const float base = std::atan2(-obj.y(), -obj.x());  // towards the room centre
    const float a = base + (u - 0.5f) * (50.f * kPi / 180.f);
    *e = obj + Vector3f(0.95f * std::cos(a), 0.95f * std::sin(a), 0.45f);
    e->x() = std::clamp(e->x(), -half_w, half_w);
    e->y() = std::clamp(e->y(), -half_d, half_d);
    *t = obj;
  };
  if (objects.empty()) {
    *eye = Vector3f(-half_w, -half_d, 1.3f);
    *target = Vector3f(0, 0, 0.8f);
    return;
  }
  const float share = static_cast<float>(n) / objects.size();
  const size_t k = std::min(objects.size() - 1, static_cast<size_t>(i / share));
  const float f = (i - k * share) / share;  // 0..1 within object k's share
  const bool forward = k % 2 == 0;          // arcs alternate direction
  if (f < 0.6f || k + 1 == objects.size()) {
    const float u = std::min(f / 0.6f, 1.0f);
    view(k, forward ? u : 1 - u, eye, target);
    return;
  }
  // Moving on: from the end of arc k to the start of arc k + 1 (smoothstep).
  Vector3f e0, t0, e1, t1;
  view(k, forward ? 1.f : 0.f, &e0, &t0);
  view(k + 1, forward ? 1.f : 0.f, &e1, &t1);
  float w = (f - 0.6f) / 0.4f;
  w = w * w * (3 - 2 * w);
  *eye = e0 + w * (e1 - e0);
  *target = t0 + w * (t1 - t0);
}

// The base's loop (rectangle w x d half-sizes, counter-clockwise): position at path length
// s and the driving direction.
void LoopAt(float w, float d, float s, Vector3f* p, Vector3f* dir) {
  const float perim = 4 * (w + d);
  float u = std::fmod(s, perim);
  if (u < 2 * w) {
    *p = {-w + u, -d, 0}, *dir = {1, 0, 0};
  } else if ((u -= 2 * w) < 2 * d) {
    *p = {w, -d + u, 0}, *dir = {0, 1, 0};
  } else if ((u -= 2 * d) < 2 * w) {
    *p = {w - u, d, 0}, *dir = {-1, 0, 0};
  } else {
    u -= 2 * w;
    *p = {-w, d - u, 0}, *dir = {0, -1, 0};
  }
}

// Angle a - b wrapped to (-pi, pi].
float AngleDiff(float a, float b) {
  float d = std::fmod(a - b, 2 * kPi);
  if (d > kPi) d -= 2 * kPi;
  if (d <= -kPi) d += 2 * kPi;
  return d;
}

// The patrol (see the header), all frames: the head's yaw and pitch are filtered state.
std::vector<Eigen::Isometry3f> Patrol(const SceneLayout& scene, const TrajectoryOptions& o) {
  std::vector<Eigen::Isometry3f> out;
  const float w = scene.spec.width / 2 - 1.0f, d = scene.spec.depth / 2 - 1.0f;
  std::vector<Vector3f> interest;
  for (const Support& sup : scene.supports) {
    const Vector2f c = (sup.min + sup.max) / 2;
    interest.push_back({c.x(), c.y(), sup.z});
  }
  const float dt = static_cast<float>(1 / o.fps), alpha = 1 - std::exp(-dt / 0.8f);
  float yaw = 0, pitch = 20 * kPi / 180;
  for (int i = 0; i < o.frames; ++i) {
    const float t = static_cast<float>(i / o.fps);
    Vector3f p, dir;
    LoopAt(w, d, static_cast<float>(o.speed) * t, &p, &dir);
    p.z() = o.height + (o.shake ? 0.01f * std::sin(2 * kPi * t * 1.8f) : 0.f);
    const float heading = std::atan2(dir.y(), dir.x());
    // Default: ahead and inward (the room centre is on the left of a counter-clockwise loop).
    float want_yaw = heading + 0.5f, want_pitch = 20 * kPi / 180;
    float best = 4.0f;
    for (const Vector3f& c : interest) {
      const Vector2f to = (c - p).head<2>();
      const float dist = to.norm();
      const float a = std::atan2(to.y(), to.x());
      if (dist < best && dist > 1.2f && std::abs(AngleDiff(a, heading)) < 100 * kPi / 180) {
        best = dist;
        want_yaw = a;
        want_pitch = std::clamp(std::atan2(p.z() - c.z(), dist), 10 * kPi / 180, 35 * kPi / 180);
      }
    }
    want_yaw += 15 * kPi / 180 * std::sin(2 * kPi * t / 6.f);
    if (i == 0) yaw = want_yaw, pitch = want_pitch;
    yaw += alpha * AngleDiff(want_yaw, yaw);
    pitch += alpha * (want_pitch - pitch);
    const Vector3f look(std::cos(yaw) * std::cos(pitch), std::sin(yaw) * std::cos(pitch),
                        -std::sin(pitch));
    out.push_back(LookAt(p, p + look));
  }
  return out;
}

}  // namespace

std::vector<Eigen::Isometry3f> MakeTrajectory(const SceneLayout& scene,
                                              const TrajectoryOptions& o) {
  if (o.kind == TrajectoryKind::kPatrol) return Patrol(scene, o);
  std::vector<Eigen::Isometry3f> out;
  const Tremor tremor(o.seed);
  const Support* table = nullptr;
  const Support* shelf = nullptr;
  for (const Support& s : scene.supports) {
    if (!table && s.name.rfind("table", 0) == 0) table = &s;
    if (!shelf && s.name.rfind("shelf", 0) == 0) shelf = &s;
  }
  TrajectoryKind kind = o.kind;
  if (kind == TrajectoryKind::kSweep && !shelf) kind = TrajectoryKind::kOrbit;
  const float w = scene.spec.width / 2 - 1.0f, d = scene.spec.depth / 2 - 1.0f;
  for (int i = 0; i < o.frames; ++i) {
    const float t = static_cast<float>(i / o.fps);
    const float s = static_cast<float>(o.speed) * t;  // path length so far
    Eigen::Isometry3f T;
    if (kind == TrajectoryKind::kTour) {
      Vector3f eye, target;
      TourAt(scene, i, o.frames, &eye, &target);
      T = LookAt(eye, target);
    } else if (kind == TrajectoryKind::kOrbit && table) {
      const Vector2f c2 = (table->min + table->max) / 2;
      const Vector3f c(c2.x(), c2.y(), table->z + 0.05f);
      const float r = 1.3f, a = s / r - kPi / 2;
      T = LookAt(c + Vector3f(r * std::cos(a), r * std::sin(a), 0.7f), c);
    } else if (kind == TrajectoryKind::kSweep) {
      const Vector2f c2 = (shelf->min + shelf->max) / 2;
      const bool north = c2.y() > 0, along_x = shelf->max.x() - shelf->min.x() > 0.5f;
      const Vector3f n = along_x ? Vector3f(0, north ? -1.f : 1.f, 0) : Vector3f(1, 0, 0);
      const Vector3f side = along_x ? Vector3f(1, 0, 0) : Vector3f(0, 1, 0);
      const float lateral = 0.8f * std::sin(s / 0.8f);  // +-0.8 m back and forth
      const float look_z = 0.9f + 0.4f * std::sin(0.37f * s);
      const Vector3f base(c2.x(), c2.y(), 0);
      T = LookAt(base + 1.1f * n + lateral * side + Vector3f(0, 0, 1.3f),
                 base + 0.6f * lateral * side + Vector3f(0, 0, look_z));
    } else {  // robot loop (rectangle, counter-clockwise) or orbit without tables
      Vector3f p, dir;
      LoopAt(w, d, s, &p, &dir);
      const float yaw = 0.5f + 0.6f * std::sin(2 * kPi * t / 7.f);  // look inward and around
      const Vector3f look = Eigen::AngleAxisf(yaw, Vector3f::UnitZ()) * dir;
      const float bob = o.shake ? 0.01f * std::sin(2 * kPi * t * 1.8f) : 0.f;
      p.z() = o.height + bob;
      T = LookAt(p, p + look + Vector3f(0, 0, -std::tan(20.f * kPi / 180.f)));
    }
    if (o.shake && kind != TrajectoryKind::kRobot) T = Perturb(T, tremor, t, 0.01f, 0.012f);
    out.push_back(T);
  }
  return out;
}

std::vector<Eigen::Isometry3f> MakeTrainingOrbit(const Vector3f& target, float radius,
                                                 float elevation_deg, float azimuth0_deg,
                                                 int frames) {
  std::vector<Eigen::Isometry3f> out;
  const float e = elevation_deg * kPi / 180.f;
  for (int i = 0; i < frames; ++i) {
    const float a = (azimuth0_deg * kPi / 180.f) + 2 * kPi * i / frames;
    const Vector3f eye = target + radius * Vector3f(std::cos(e) * std::cos(a),
                                                    std::cos(e) * std::sin(a), std::sin(e));
    out.push_back(LookAt(eye, target));
  }
  return out;
}

}  // namespace skimap::sim
