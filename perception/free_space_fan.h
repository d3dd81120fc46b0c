// The fan of a frame's rays seen from above (perception/free_space.h): the pieces of
// BuildFreeSpaceBatch that bin rays by azimuth and merge their radius intervals.
// Internal to skimap_perception.
//
// Thread safety: pure functions and values.
#ifndef PERCEPTION_FREE_SPACE_FAN_H_
#define PERCEPTION_FREE_SPACE_FAN_H_

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <numbers>
#include <span>
#include <vector>

namespace skimap::perception::internal {

inline constexpr double kPi = std::numbers::pi;

// atan2 within 1.1e-5 rad: the Abramowitz & Stegun 4.4.49 polynomial for atan on [0, 1],
// extended to the plane by octant symmetry. Deterministic, a few times cheaper than
// std::atan2, and the same function bins rays and cells, so its error cancels.
inline double FastAtan2(double y, double x) {
  const double ax = std::abs(x), ay = std::abs(y);
  const double lo = std::min(ax, ay), hi = std::max(ax, ay);
  if (hi == 0) return 0;
  const double t = lo / hi, t2 = t * t;
  double a =
      t * (0.9998660 + t2 * (-0.3302995 + t2 * (0.1801410 + t2 * (-0.0851330 + t2 * 0.0208351))));
  if (ay > ax) a = 0.5 * kPi - a;
  if (x < 0) a = kPi - a;
  return y < 0 ? -a : a;
}

// Wraps an angle difference into (-pi, pi].
inline double Wrap(double a) {
  if (a > kPi) return a - 2 * kPi;
  if (a <= -kPi) return a + 2 * kPi;
  return a;
}

// One ray's part inside the slab, seen from above: the half-line from the camera's column
// at `angle` (radians from the reference azimuth), from radius r0 to r1 (metres).
struct FanRay {
  double angle, r0, r1;
};
struct Interval {
  double r0, r1;
};

// The fan of a frame: per angular bin, the union of the radius intervals its rays carved.
struct Fan {
  double min_angle = 0, bin_width = 0, max_r = 0;
  std::vector<uint32_t> first;  // bin b's intervals: [first[b], first[b + 1])
  std::vector<Interval> intervals;
  size_t bins() const { return first.empty() ? 0 : first.size() - 1; }
  std::span<const Interval> Of(size_t b) const {
    return {intervals.data() + first[b], first[b + 1] - first[b]};
  }
};

// Bins the rays (bins one column wide at the farthest reach) and fills the bins between two
// neighbouring rays (at most max_gap apart) with what both carved: the fan between two
// neighbouring rays is free up to the nearer one.
Fan MakeFan(const std::vector<FanRay>& rays, double res, double max_gap, bool from_camera);

}  // namespace skimap::perception::internal

#endif  // PERCEPTION_FREE_SPACE_FAN_H_
