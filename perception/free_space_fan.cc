#include "perception/free_space_fan.h"

#include <algorithm>

namespace skimap::perception::internal {
namespace {

constexpr size_t kMaxBins = size_t{1} << 15;

// Appends the union of the rays [first, last) to *out, sorted; intervals closer than `join`
// merge.
void MergeIntervals(FanRay* first, FanRay* last, double join, std::vector<Interval>* out) {
  std::sort(first, last, [](const FanRay& a, const FanRay& b) { return a.r0 < b.r0; });
  Interval cur{first->r0, first->r1};
  for (const FanRay* it = first + 1; it != last; ++it) {
    if (it->r0 <= cur.r1 + join) {
      cur.r1 = std::max(cur.r1, it->r1);
    } else {
      out->push_back(cur);
      cur = {it->r0, it->r1};
    }
  }
  out->push_back(cur);
}

// Appends the intersection of two sorted, disjoint interval lists to *out.
void IntersectIntervals(std::span<const Interval> a, std::span<const Interval> b,
                        std::vector<Interval>* out) {
  size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    const double lo = std::max(a[i].r0, b[j].r0), hi = std::min(a[i].r1, b[j].r1);
    if (lo <= hi) out->push_back({lo, hi});
    (a[i].r1 < b[j].r1 ? i : j)++;
  }
}

}  // namespace

Fan MakeFan(const std::vector<FanRay>& rays, double res, double max_gap, bool from_camera) {
  Fan fan;
  double max_angle = -kPi;
  fan.min_angle = kPi;
  for (const FanRay& r : rays) {
    fan.min_angle = std::min(fan.min_angle, r.angle);
    max_angle = std::max(max_angle, r.angle);
    fan.max_r = std::max(fan.max_r, r.r1);
  }
  fan.bin_width = std::max(res / fan.max_r, (max_angle - fan.min_angle) / double(kMaxBins - 1));
  const size_t bins = size_t((max_angle - fan.min_angle) / fan.bin_width) + 1;
  auto bin_of = [&](double angle) {
    return std::min(bins - 1, size_t((angle - fan.min_angle) / fan.bin_width));
  };
  // Each bin's own intervals.
  std::vector<uint32_t> own(bins + 1, 0);
  std::vector<Interval> merged;
  if (from_camera) {  // every ray starts at the camera: a bin's union is [0, its farthest]
    std::vector<double> reach(bins, -1);
    for (const FanRay& r : rays) {
      double& m = reach[bin_of(r.angle)];
      m = std::max(m, r.r1);
    }
    for (size_t b = 0; b < bins; ++b) {
      own[b] = uint32_t(merged.size());
      if (reach[b] >= 0) merged.push_back({0, reach[b]});
    }
  } else {
    std::vector<uint32_t> start(bins + 1, 0);
    for (const FanRay& r : rays) ++start[bin_of(r.angle) + 1];
    for (size_t b = 0; b < bins; ++b) start[b + 1] += start[b];
    std::vector<FanRay> sorted(rays.size());
    std::vector<uint32_t> fill(start.begin(), start.end() - 1);
    for (const FanRay& r : rays) sorted[fill[bin_of(r.angle)]++] = r;
    for (size_t b = 0; b < bins; ++b) {
      own[b] = uint32_t(merged.size());
      if (start[b] < start[b + 1]) {
        MergeIntervals(sorted.data() + start[b], sorted.data() + start[b + 1], res, &merged);
      }
    }
  }
  own[bins] = uint32_t(merged.size());
  std::vector<uint32_t> next(bins + 1, uint32_t(bins));  // the first bin >= b with rays
  for (size_t b = bins; b-- > 0;) next[b] = own[b] < own[b + 1] ? uint32_t(b) : next[b + 1];
  fan.first.assign(bins + 1, 0);
  size_t left = bins;  // the last bin with rays; none yet
  for (size_t b = 0; b < bins; ++b) {
    fan.first[b] = uint32_t(fan.intervals.size());
    const std::span<const Interval> mine(merged.data() + own[b], own[b + 1] - own[b]);
    if (!mine.empty()) {
      fan.intervals.insert(fan.intervals.end(), mine.begin(), mine.end());
      left = b;
      continue;
    }
    const size_t right = next[b];
    if (left == bins || right == bins || double(right - left) * fan.bin_width > max_gap) continue;
    IntersectIntervals({merged.data() + own[left], own[left + 1] - own[left]},
                       {merged.data() + own[right], own[right + 1] - own[right]}, &fan.intervals);
  }
  fan.first[bins] = uint32_t(fan.intervals.size());
  return fan;
}

}  // namespace skimap::perception::internal
