#include "perception/objects/mean_shift.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <numeric>

#include "absl/strings/str_cat.h"

namespace skimap::objects {
namespace {

// One mode (a centroid in its own one-row matrix) and the number of points within the
// bandwidth of it (its support, used to rank modes when merging).
struct Mode {
  std::vector<uint8_t> bits;
  std::vector<float> values;
  size_t support = 0;
  DescriptorRef ref() const {
    return bits.empty() ? DescriptorRef{.values = values.data()}
                        : DescriptorRef{.bits = bits.data()};
  }
};

double KernelWeight(const MeanShiftOptions& o, double d) {
  if (o.kernel == MeanShiftKernel::kFlat) return d <= o.bandwidth ? 1.0 : 0.0;
  if (d > 3 * o.bandwidth) return 0.0;
  return std::exp(-0.5 * (d * d) / (o.bandwidth * o.bandwidth));
}

// Weighs every point by the kernel around mode m: add(point, weight) for each point of
// non-zero weight; sets m->support (points within the bandwidth). Returns the total weight.
template <class Add>
double WeighPoints(const DescriptorMatrix& pts, const MeanShiftOptions& o, Mode* m, Add add) {
  double total = 0;
  size_t support = 0;
  for (size_t i = 0; i < pts.rows(); ++i) {
    const DescriptorRef p = pts.Row(i);
    const double d = DescriptorDistance(pts.layout(), m->ref(), p);
    const double w = KernelWeight(o, d);
    if (d <= o.bandwidth) ++support;
    if (w == 0) continue;
    total += w;
    add(p, w);
  }
  m->support = support;
  return total;
}

// One shift of a binary mode: weighted per-bit majority. Returns true if it moved.
bool ShiftBinary(const DescriptorMatrix& pts, const MeanShiftOptions& o, Mode* m,
                 std::vector<double>* votes) {
  const DescriptorLayout& l = pts.layout();
  std::fill(votes->begin(), votes->end(), 0.0);
  const int bytes = (l.dims + 7) / 8;
  const double total = WeighPoints(pts, o, m, [&](const DescriptorRef& p, double w) {
    // The set bits only, in ascending order (each vote's sum in the same order as a loop
    // over every bit).
    for (int byte = 0; byte < bytes; ++byte) {
      for (unsigned v = p.bits[byte]; v != 0; v &= v - 1) {
        const int b = byte * 8 + std::countr_zero(v);
        if (b < l.dims) (*votes)[b] += w;
      }
    }
  });
  if (total == 0) return false;
  bool moved = false;
  for (int b = 0; b < l.dims; ++b) {
    const uint8_t mask = static_cast<uint8_t>(1u << (b & 7));
    const bool cur = (m->bits[b >> 3] & mask) != 0;
    const double ones = (*votes)[b];
    const bool next = ones * 2 > total ? true : ones * 2 < total ? false : cur;  // tie: keep
    if (next != cur) {
      m->bits[b >> 3] ^= mask;
      moved = true;
    }
  }
  return moved;
}

// One shift of a float mode: weighted mean. Returns true if it moved more than a tiny
// fraction of the bandwidth.
bool ShiftFloat(const DescriptorMatrix& pts, const MeanShiftOptions& o, Mode* m,
                std::vector<double>* sum) {
  const DescriptorLayout& l = pts.layout();
  std::fill(sum->begin(), sum->end(), 0.0);
  const double total = WeighPoints(pts, o, m, [&](const DescriptorRef& p, double w) {
    for (int k = 0; k < l.dims; ++k) (*sum)[k] += w * p.values[k];
  });
  if (total == 0) return false;
  double moved2 = 0;
  for (int k = 0; k < l.dims; ++k) {
    const float next = static_cast<float>((*sum)[k] / total);
    const double d = next - m->values[k];
    moved2 += d * d;
    m->values[k] = next;
  }
  return std::sqrt(moved2) > 1e-4 * o.bandwidth;
}

}  // namespace

absl::Status ValidateMeanShiftOptions(const MeanShiftOptions& o) {
  if (!(o.bandwidth > 0) || !std::isfinite(o.bandwidth)) {
    return absl::InvalidArgumentError(
        absl::StrCat("bandwidth: ", o.bandwidth, " must be a finite value > 0"));
  }
  if (o.kernel != MeanShiftKernel::kFlat && o.kernel != MeanShiftKernel::kGaussian) {
    return absl::InvalidArgumentError("kernel: must be flat or gaussian");
  }
  if (o.max_iterations < 1) {
    return absl::InvalidArgumentError(
        absl::StrCat("max_iterations: ", o.max_iterations, " must be >= 1"));
  }
  if (o.max_seeds < 1) {
    return absl::InvalidArgumentError(absl::StrCat("max_seeds: ", o.max_seeds, " must be >= 1"));
  }
  return absl::OkStatus();
}

absl::StatusOr<Clusters> MeanShift(const DescriptorMatrix& points,
                                   const MeanShiftOptions& options) {
  if (absl::Status s = ValidateMeanShiftOptions(options); !s.ok()) return s;
  Clusters out;
  out.centroids = DescriptorMatrix(points.layout());
  if (points.empty()) return out;
  const DescriptorLayout& l = points.layout();
  const size_t n = points.rows();
  const size_t seeds = std::min<size_t>(n, static_cast<size_t>(options.max_seeds));

  std::vector<Mode> modes;
  modes.reserve(seeds);
  std::vector<double> scratch(l.dims);
  for (size_t s = 0; s < seeds; ++s) {
    const DescriptorRef p = points.Row(s * n / seeds);
    Mode m;
    if (l.binary()) {
      m.bits.assign(p.bits, p.bits + l.dims / 8);
    } else {
      m.values.assign(p.values, p.values + l.dims);
    }
    for (int it = 0; it < options.max_iterations; ++it) {
      const bool moved = l.binary() ? ShiftBinary(points, options, &m, &scratch)
                                    : ShiftFloat(points, options, &m, &scratch);
      if (!moved) break;
    }
    modes.push_back(std::move(m));
  }

  // Merge: strongest support first; a mode within bandwidth / 2 of a kept one is dropped.
  std::vector<size_t> order(modes.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t a, size_t b) { return modes[a].support > modes[b].support; });
  std::vector<const Mode*> kept;
  for (size_t i : order) {
    bool near = false;
    for (const Mode* k : kept) {
      if (DescriptorDistance(l, k->ref(), modes[i].ref()) <= options.bandwidth / 2) {
        near = true;
        break;
      }
    }
    if (!near) kept.push_back(&modes[i]);
  }

  // Assign each point to its nearest kept mode.
  std::vector<uint32_t> count(kept.size(), 0);
  for (size_t i = 0; i < n; ++i) {
    size_t best = 0;
    float best_d = INFINITY;
    for (size_t k = 0; k < kept.size(); ++k) {
      const float d = DescriptorDistance(l, kept[k]->ref(), points.Row(i));
      if (d < best_d) {
        best_d = d;
        best = k;
      }
    }
    ++count[best];
  }
  for (size_t k = 0; k < kept.size(); ++k) {
    if (count[k] == 0) continue;
    out.centroids.Append(kept[k]->ref());
    out.cardinalities.push_back(count[k]);
  }
  return out;
}

}  // namespace skimap::objects
