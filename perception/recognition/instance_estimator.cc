#include "perception/recognition/instance_estimator.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "absl/container/flat_hash_set.h"

namespace skimap::recognition {

float RotationAngle(const Eigen::Quaternionf& a, const Eigen::Quaternionf& b) {
  const float d = std::min(1.0f, std::abs(a.normalized().dot(b.normalized())));
  return 2 * std::acos(d);
}

std::vector<InstanceEstimate> EstimateInstances(std::span<const HypothesisSample> hypotheses,
                                                const ClusterOptions& options) {
  const size_t n = hypotheses.size();
  std::vector<size_t> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t a, size_t b) { return hypotheses[a].score > hypotheses[b].score; });
  std::vector<bool> used(n, false);
  std::vector<InstanceEstimate> out;
  const float r2 = options.radius * options.radius;
  for (size_t seed : order) {
    if (used[seed]) continue;
    std::vector<size_t> group;
    for (size_t i : order) {
      if (!used[i] && (hypotheses[i].t - hypotheses[seed].t).squaredNorm() <= r2) {
        group.push_back(i);
        used[i] = true;
      }
    }
    // Orientation clustering: the member with the most score within max_angle is the centre.
    size_t centre = group.front();
    float best = -1;
    for (size_t i : group) {
      float w = 0;
      for (size_t j : group) {
        if (RotationAngle(hypotheses[i].q, hypotheses[j].q) <= options.max_angle) {
          w += hypotheses[j].score;
        }
      }
      if (w > best) {
        best = w;
        centre = i;
      }
    }
    std::vector<size_t> cluster;
    for (size_t i : group) {
      if (RotationAngle(hypotheses[centre].q, hypotheses[i].q) <= options.max_angle) {
        cluster.push_back(i);
      }
    }
    absl::flat_hash_set<uint64_t> frames;
    for (size_t i : cluster) frames.insert(hypotheses[i].frame);
    if (static_cast<int>(cluster.size()) < options.min_support ||
        static_cast<int>(frames.size()) < options.min_frames) {
      continue;
    }
    InstanceEstimate e;
    Eigen::Vector4f qsum = Eigen::Vector4f::Zero();
    Eigen::Vector3f tsum = Eigen::Vector3f::Zero();
    const Eigen::Quaternionf& qc = hypotheses[centre].q;
    e.first_frame = hypotheses[cluster.front()].frame;
    for (size_t i : cluster) {
      const HypothesisSample& h = hypotheses[i];
      const float w = std::max(h.score, 1e-6f);
      Eigen::Vector4f q = h.q.coeffs();
      if (q.dot(qc.coeffs()) < 0) q = -q;
      qsum += w * q;
      tsum += w * h.t;
      e.score += h.score;
      e.first_frame = std::min(e.first_frame, h.frame);
      e.last_frame = std::max(e.last_frame, h.frame);
    }
    float wsum = 0;
    for (size_t i : cluster) wsum += std::max(hypotheses[i].score, 1e-6f);
    e.q = Eigen::Quaternionf(qsum.normalized());  // coeffs order x, y, z, w
    e.t = tsum / wsum;
    e.support = static_cast<int>(cluster.size());
    e.frames = static_cast<int>(frames.size());
    float st = 0, sr = 0;
    for (size_t i : cluster) {
      st += (hypotheses[i].t - e.t).squaredNorm();
      const float a = RotationAngle(hypotheses[i].q, e.q);
      sr += a * a;
    }
    e.spread_t = std::sqrt(st / cluster.size());
    e.spread_r = std::sqrt(sr / cluster.size());
    out.push_back(e);
  }
  std::sort(out.begin(), out.end(),
            [](const InstanceEstimate& a, const InstanceEstimate& b) { return a.score > b.score; });
  return out;
}

}  // namespace skimap::recognition
