#include "perception/recognition/pose_voting.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "Eigen/Geometry"
#include "Eigen/LU"
#include "absl/container/flat_hash_map.h"

namespace skimap::recognition {
namespace {

struct Cell {
  int32_t x, y, z;
  bool operator==(const Cell&) const = default;
  template <class H>
  friend H AbslHashValue(H h, const Cell& c) {
    return H::combine(std::move(h), c.x, c.y, c.z);
  }
};

Eigen::Isometry3f FromMatrix(const Eigen::Matrix4f& m) {
  Eigen::Isometry3f t = Eigen::Isometry3f::Identity();
  t.linear() = m.topLeftCorner<3, 3>();
  t.translation() = m.topRightCorner<3, 1>();
  return t;
}

// Inlier weight and count of `pose` over `matches`.
void Score(std::span<const LabelMatch> matches, const Eigen::Isometry3f& pose, float distance,
           float* score, int* inliers) {
  const float d2 = distance * distance;
  *score = 0;
  *inliers = 0;
  for (const LabelMatch& m : matches) {
    if ((pose * m.model - m.world).squaredNorm() <= d2) {
      *score += m.weight;
      ++*inliers;
    }
  }
}

// True if the triple is geometrically consistent (see the header).
bool Consistent(const LabelMatch& a, const LabelMatch& b, const LabelMatch& c,
                const VotingOptions& o) {
  const LabelMatch* t[3] = {&a, &b, &c};
  float longest = 0;
  for (int i = 0; i < 3; ++i) {
    const LabelMatch& p = *t[i];
    const LabelMatch& q = *t[(i + 1) % 3];
    const float dm = (p.model - q.model).norm();
    const float dw = (p.world - q.world).norm();
    if (dm < o.min_side || std::abs(dm - dw) > o.consistency) return false;
    longest = std::max(longest, dm);
  }
  // Not collinear: the triangle's height over its longest side.
  const float twice_area = (b.model - a.model).cross(c.model - a.model).norm();
  return twice_area / longest >= 0.5f * o.min_side;
}

}  // namespace

Eigen::Isometry3f FitRigid(std::span<const LabelMatch> matches) {
  Eigen::Matrix3Xf src(3, matches.size()), dst(3, matches.size());
  for (size_t i = 0; i < matches.size(); ++i) {
    src.col(i) = matches[i].model;
    dst.col(i) = matches[i].world;
  }
  return FromMatrix(Eigen::umeyama(src, dst, /*with_scaling=*/false));
}

PoseEstimate RefinePose(std::span<const LabelMatch> matches, const Eigen::Isometry3f& pose,
                        float distance) {
  PoseEstimate best;
  best.pose = pose;
  Score(matches, pose, distance, &best.score, &best.inliers);
  std::vector<LabelMatch> inliers;
  for (int round = 0; round < 2 && best.inliers >= 3; ++round) {
    const float d2 = distance * distance;
    inliers.clear();
    for (const LabelMatch& m : matches) {
      if ((best.pose * m.model - m.world).squaredNorm() <= d2) inliers.push_back(m);
    }
    const Eigen::Isometry3f refit = FitRigid(inliers);
    PoseEstimate next;
    next.pose = refit;
    Score(matches, refit, distance, &next.score, &next.inliers);
    if (!(next.score >= best.score)) break;  // also rejects a NaN fit
    best = next;
  }
  return best;
}

std::vector<PoseEstimate> VotePoses(std::span<const LabelMatch> matches, const ObjectShape& shape,
                                    const Sphere& sphere, const VotingOptions& options,
                                    std::mt19937_64& rng) {
  std::vector<PoseEstimate> out;
  const size_t n = matches.size();
  if (n < 3) return out;
  std::vector<double> cumulative(n);
  double total = 0;
  for (size_t i = 0; i < n; ++i) cumulative[i] = total += matches[i].weight;
  std::uniform_real_distribution<double> uniform(0, total);
  auto draw = [&] {
    return static_cast<size_t>(
               std::upper_bound(cumulative.begin(), cumulative.end(), uniform(rng)) -
               cumulative.begin()) %
           n;
  };

  // Votes: the transforms, and per bin the indices of those that voted for it.
  std::vector<Eigen::Isometry3f> transforms;
  absl::flat_hash_map<Cell, std::vector<int>> bins;
  const float reach = sphere.radius + shape.radius;
  const float inv_bin = 1.0f / options.bin;
  for (int k = 0; k < options.triples; ++k) {
    const size_t i = draw(), j = draw(), l = draw();
    if (i == j || j == l || i == l) continue;
    if (!Consistent(matches[i], matches[j], matches[l], options)) continue;
    const LabelMatch triple[3] = {matches[i], matches[j], matches[l]};
    const Eigen::Isometry3f t = FitRigid(triple);
    const Eigen::Vector3f base = t * shape.base - sphere.centre;
    if (!base.allFinite() || base.norm() > reach) continue;
    const Cell cell{static_cast<int32_t>(std::floor(base.x() * inv_bin)),
                    static_cast<int32_t>(std::floor(base.y() * inv_bin)),
                    static_cast<int32_t>(std::floor(base.z() * inv_bin))};
    bins[cell].push_back(static_cast<int>(transforms.size()));
    transforms.push_back(t);
  }

  std::vector<std::pair<int, Cell>> peaks;
  for (const auto& [cell, votes] : bins) {
    if (static_cast<int>(votes.size()) >= options.min_votes) {
      peaks.push_back({static_cast<int>(votes.size()), cell});
    }
  }
  std::sort(peaks.begin(), peaks.end(), [](const auto& a, const auto& b) {
    if (a.first != b.first) return a.first > b.first;
    return std::tie(a.second.x, a.second.y, a.second.z) <
           std::tie(b.second.x, b.second.y, b.second.z);  // deterministic order
  });
  std::vector<Cell> taken;
  for (const auto& [votes, cell] : peaks) {
    if (static_cast<int>(out.size()) >= options.max_peaks) break;
    const bool adjacent = std::any_of(taken.begin(), taken.end(), [&](const Cell& t) {
      return std::abs(t.x - cell.x) <= 1 && std::abs(t.y - cell.y) <= 1 &&
             std::abs(t.z - cell.z) <= 1;
    });
    if (adjacent) continue;
    taken.push_back(cell);
    // The best transform among those of the peak's neighbourhood, refit on its inliers.
    PoseEstimate best;
    for (int dx = -1; dx <= 1; ++dx) {
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dz = -1; dz <= 1; ++dz) {
          auto it = bins.find(Cell{cell.x + dx, cell.y + dy, cell.z + dz});
          if (it == bins.end()) continue;
          for (int index : it->second) {
            PoseEstimate e;
            e.pose = transforms[index];
            Score(matches, e.pose, options.inlier_distance, &e.score, &e.inliers);
            if (e.score > best.score) best = e;
          }
        }
      }
    }
    PoseEstimate refined = RefinePose(matches, best.pose, options.inlier_distance);
    refined.votes = votes;
    if (refined.score >= options.min_score && refined.inliers >= 3) out.push_back(refined);
  }
  std::sort(out.begin(), out.end(),
            [](const PoseEstimate& a, const PoseEstimate& b) { return a.score > b.score; });
  return out;
}

}  // namespace skimap::recognition
