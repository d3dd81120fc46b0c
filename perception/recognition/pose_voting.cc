#include "perception/recognition/pose_voting.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "Eigen/Geometry"
#include "Eigen/LU"
#include "Eigen/SVD"
#include "absl/container/flat_hash_map.h"
#include "absl/random/discrete_distribution.h"

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

Eigen::Isometry3f FitRigidWeighted(std::span<const LabelMatch> matches,
                                   std::span<const float> weights) {
  Eigen::Vector3f cm = Eigen::Vector3f::Zero(), cw = Eigen::Vector3f::Zero();
  float total = 0;
  for (size_t i = 0; i < matches.size(); ++i) {
    cm += weights[i] * matches[i].model;
    cw += weights[i] * matches[i].world;
    total += weights[i];
  }
  Eigen::Isometry3f t = Eigen::Isometry3f::Identity();
  if (!(total > 0)) return t;
  cm /= total;
  cw /= total;
  Eigen::Matrix3f cov = Eigen::Matrix3f::Zero();
  for (size_t i = 0; i < matches.size(); ++i) {
    cov += weights[i] * (matches[i].world - cw) * (matches[i].model - cm).transpose();
  }
  const Eigen::JacobiSVD<Eigen::Matrix3f> svd(cov, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3f d = Eigen::Matrix3f::Identity();
  if ((svd.matrixU() * svd.matrixV().transpose()).determinant() < 0) d(2, 2) = -1;
  t.linear() = svd.matrixU() * d * svd.matrixV().transpose();
  t.translation() = cw - t.linear() * cm;
  return t;
}

namespace {

// Summed weight of the matches, each scaled by a Gaussian of its residual (sigma); the
// residuals past 3 sigma count nothing. Tighter fits score more, unlike a plain count.
float SoftScore(std::span<const LabelMatch> matches, const Eigen::Isometry3f& pose, float sigma,
                std::vector<float>* weights) {
  const float inv = 1.0f / (2 * sigma * sigma), cut = 9 * sigma * sigma;
  float total = 0;
  weights->resize(matches.size());
  for (size_t i = 0; i < matches.size(); ++i) {
    const float d2 = (pose * matches[i].model - matches[i].world).squaredNorm();
    (*weights)[i] = d2 < cut ? matches[i].weight * std::exp(-d2 * inv) : 0;
    total += (*weights)[i];
  }
  return total;
}

}  // namespace

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
  // Then iteratively reweighted least squares with Gaussian weights (sigma = distance / 2):
  // among poses that keep about the same inliers, the one they fit tightest. On a small
  // object the inlier count alone cannot tell a pose from one turned by 20 degrees.
  if (best.inliers >= 3) {
    const float sigma = distance / 2;
    std::vector<float> weights;
    float soft = SoftScore(matches, best.pose, sigma, &weights);
    for (int round = 0; round < 4; ++round) {
      const Eigen::Isometry3f refit = FitRigidWeighted(matches, weights);
      std::vector<float> next_weights;
      const float next_soft = SoftScore(matches, refit, sigma, &next_weights);
      if (!(next_soft > soft)) break;
      soft = next_soft;
      weights = std::move(next_weights);
      best.pose = refit;
    }
    Score(matches, best.pose, distance, &best.score, &best.inliers);
  }
  return best;
}

std::vector<PoseEstimate> VotePoses(std::span<const LabelMatch> matches, const ObjectShape& shape,
                                    const Sphere& sphere, const VotingOptions& options,
                                    std::mt19937_64& rng) {
  std::vector<PoseEstimate> out;
  const size_t n = matches.size();
  if (n < 3) return out;
  // The first match of a triple: drawn in proportion to its weight, in O(1) per draw
  // (absl's discrete_distribution is Walker's alias method; a binary search over the
  // cumulative weights was most of the voting's time with thousands of matches).
  std::vector<double> weights(n);
  for (size_t i = 0; i < n; ++i) weights[i] = matches[i].weight;
  absl::discrete_distribution<size_t> first(weights.begin(), weights.end());
  auto draw = [&] { return first(rng); };
  // Local sampling: the second and third match of a triple lie within the object's
  // diameter of the first in the world (an object's true matches do; most outliers, spread
  // over the sphere, do not), found through a hash grid of that cell size.
  const float diameter = 2 * shape.radius;
  const float inv_cell = 1.0f / std::max(diameter, 0.01f);
  auto cell_of = [&](const Eigen::Vector3f& p) {
    return Cell{static_cast<int32_t>(std::floor(p.x() * inv_cell)),
                static_cast<int32_t>(std::floor(p.y() * inv_cell)),
                static_cast<int32_t>(std::floor(p.z() * inv_cell))};
  };
  absl::flat_hash_map<Cell, std::vector<uint32_t>> grid;
  for (size_t i = 0; i < n; ++i)
    grid[cell_of(matches[i].world)].push_back(static_cast<uint32_t>(i));
  // The matches of each occupied cell's 3x3x3 block, made once per cell (cells are far
  // fewer than matches); the second and third match are drawn from the first's block and
  // kept when within the diameter (rejection sampling: uniform over the true neighbours).
  absl::flat_hash_map<Cell, std::vector<uint32_t>> blocks;
  auto block_of = [&](const Cell& c) -> const std::vector<uint32_t>& {
    auto [it, fresh] = blocks.try_emplace(c);
    if (!fresh) return it->second;
    for (int dx = -1; dx <= 1; ++dx) {
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dz = -1; dz <= 1; ++dz) {
          auto g = grid.find(Cell{c.x + dx, c.y + dy, c.z + dz});
          if (g != grid.end())
            it->second.insert(it->second.end(), g->second.begin(), g->second.end());
        }
      }
    }
    return it->second;
  };
  const float d2max = diameter * diameter;

  // Votes: the transforms, and per bin the indices of those that voted for it.
  std::vector<Eigen::Isometry3f> transforms;
  absl::flat_hash_map<Cell, std::vector<int>> bins;
  const float reach = sphere.radius + shape.radius;
  const float inv_bin = 1.0f / options.bin;
  // `triples` triples within the diameter, with at most 4 draws each.
  for (int k = 0, attempts = 0; k < options.triples && attempts < 4 * options.triples; ++attempts) {
    const size_t i = draw();
    const std::vector<uint32_t>& block = block_of(cell_of(matches[i].world));
    if (block.size() < 3) continue;
    std::uniform_int_distribution<size_t> pick(0, block.size() - 1);
    const size_t j = block[pick(rng)], l = block[pick(rng)];
    if (j == l || j == i || l == i || (matches[j].world - matches[i].world).squaredNorm() > d2max ||
        (matches[l].world - matches[i].world).squaredNorm() > d2max) {
      continue;
    }
    ++k;
    if (!Consistent(matches[i], matches[j], matches[l], options)) continue;
    const LabelMatch triple[3] = {matches[i], matches[j], matches[l]};
    constexpr float kOnes[3] = {1, 1, 1};
    const Eigen::Isometry3f t = FitRigidWeighted(triple, kOnes);  // no heap, unlike umeyama
    const Eigen::Vector3f base = t * shape.base - sphere.centre;
    if (!base.allFinite() || base.norm() > reach) continue;
    const Cell cell{static_cast<int32_t>(std::floor(base.x() * inv_bin)),
                    static_cast<int32_t>(std::floor(base.y() * inv_bin)),
                    static_cast<int32_t>(std::floor(base.z() * inv_bin))};
    bins[cell].push_back(static_cast<int>(transforms.size()));
    transforms.push_back(t);
  }

  std::vector<std::pair<int, Cell>> peaks;
  // A bin's votes count with its 26 neighbours': votes of one pose straddle bin borders.
  for (const auto& [cell, votes] : bins) {
    int total = 0;
    for (int dx = -1; dx <= 1; ++dx) {
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dz = -1; dz <= 1; ++dz) {
          auto it = bins.find(Cell{cell.x + dx, cell.y + dy, cell.z + dz});
          if (it != bins.end()) total += static_cast<int>(it->second.size());
        }
      }
    }
    if (total >= options.min_votes) peaks.push_back({total, cell});
  }
  std::sort(peaks.begin(), peaks.end(), [](const auto& a, const auto& b) {
    if (a.first != b.first) return a.first > b.first;
    return std::tie(a.second.x, a.second.y, a.second.z) <
           std::tie(b.second.x, b.second.y, b.second.z);  // deterministic order
  });
  std::vector<Cell> taken;
  for (const auto& peak : peaks) {
    const Cell& cell = peak.second;  // named, not bound: lambdas capture it (clang 14)
    if (static_cast<int>(out.size()) >= options.max_peaks) break;
    const bool adjacent = std::any_of(taken.begin(), taken.end(), [&](const Cell& t) {
      return std::abs(t.x - cell.x) <= 1 && std::abs(t.y - cell.y) <= 1 &&
             std::abs(t.z - cell.z) <= 1;
    });
    if (adjacent) continue;
    taken.push_back(cell);
    // The best transform among those of the peak's neighbourhood (at most kCandidates of
    // them, evenly taken: a strong peak holds hundreds of near-equal ones), refit on its
    // inliers.
    std::vector<int> candidates;
    for (int dx = -1; dx <= 1; ++dx) {
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dz = -1; dz <= 1; ++dz) {
          auto it = bins.find(Cell{cell.x + dx, cell.y + dy, cell.z + dz});
          if (it != bins.end())
            candidates.insert(candidates.end(), it->second.begin(), it->second.end());
        }
      }
    }
    constexpr size_t kCandidates = 24;
    const size_t step = std::max<size_t>(1, candidates.size() / kCandidates);
    PoseEstimate best;
    for (size_t c = 0; c < candidates.size(); c += step) {
      PoseEstimate e;
      e.pose = transforms[candidates[c]];
      Score(matches, e.pose, options.inlier_distance, &e.score, &e.inliers);
      if (e.score > best.score) best = e;
    }
    PoseEstimate refined = RefinePose(matches, best.pose, options.inlier_distance);
    refined.votes = peak.first;
    if (refined.score >= options.min_score && refined.inliers >= 3) out.push_back(refined);
  }
  std::sort(out.begin(), out.end(),
            [](const PoseEstimate& a, const PoseEstimate& b) { return a.score > b.score; });
  return out;
}

}  // namespace skimap::recognition
