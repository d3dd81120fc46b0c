#include "client/cli/pose_score.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <tuple>

namespace skimap::client {

PoseError ErrorUnderSymmetries(const Eigen::Isometry3d& estimate, const Eigen::Isometry3d& truth,
                               const std::vector<Eigen::Isometry3d>& symmetries) {
  auto error = [&](const Eigen::Isometry3d& t) {
    const Eigen::Quaterniond a(estimate.linear()), b(t.linear());
    return PoseError{(estimate.translation() - t.translation()).norm(),
                     a.angularDistance(b) * 180 / M_PI};
  };
  PoseError best = error(truth);
  for (const Eigen::Isometry3d& S : symmetries) {
    const PoseError e = error(truth * S);
    // The symmetric equivalent that is closest in rotation, then in translation.
    if (std::tie(e.rotation_deg, e.translation) < std::tie(best.rotation_deg, best.translation)) {
      best = e;
    }
  }
  return best;
}

Eigen::Isometry3d InstancePose(const v1::Instance& instance) {
  const v1::Quaternion& q = instance.pose().rotation();
  const v1::Vec3& t = instance.pose().translation();
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = Eigen::Quaterniond(q.w(), q.x(), q.y(), q.z()).normalized().toRotationMatrix();
  pose.translation() = Eigen::Vector3d(t.x(), t.y(), t.z());
  return pose;
}

SceneScore ScoreScene(const std::vector<TruthObject>& truths,
                      const std::vector<v1::Instance>& instances,
                      const std::map<int, dataset::ModelInfo>& models,
                      const ScoreOptions& options) {
  SceneScore score;
  score.truths = static_cast<int>(truths.size());
  score.instances = static_cast<int>(instances.size());
  score.match.assign(truths.size(), -1);
  score.error.assign(truths.size(), PoseError{});
  // Every (truth, instance) pair within tolerance, closest first.
  struct Pair {
    double translation;
    size_t truth, instance;
    PoseError error;
  };
  std::vector<Pair> pairs;
  static const std::vector<Eigen::Isometry3d> kNone;
  for (size_t t = 0; t < truths.size(); ++t) {
    auto model = models.find(truths[t].obj_id);
    const std::vector<Eigen::Isometry3d>& symmetries =
        model == models.end() ? kNone : model->second.symmetries;
    for (size_t i = 0; i < instances.size(); ++i) {
      if (instances[i].obj_id() != truths[t].obj_id) continue;
      const PoseError e =
          ErrorUnderSymmetries(InstancePose(instances[i]), truths[t].pose, symmetries);
      if (e.translation <= options.max_translation && e.rotation_deg <= options.max_rotation_deg) {
        pairs.push_back({e.translation, t, i, e});
      }
    }
  }
  std::sort(pairs.begin(), pairs.end(), [](const Pair& a, const Pair& b) {
    return std::tie(a.translation, a.truth, a.instance) <
           std::tie(b.translation, b.truth, b.instance);
  });
  std::vector<bool> instance_used(instances.size(), false);
  for (const Pair& p : pairs) {
    if (score.match[p.truth] >= 0 || instance_used[p.instance]) continue;
    score.match[p.truth] = static_cast<int>(p.instance);
    score.error[p.truth] = p.error;
    instance_used[p.instance] = true;
    ++score.true_positives;
  }
  return score;
}

double MssdError(const Eigen::Isometry3d& estimate, const Eigen::Isometry3d& truth,
                 const std::vector<Eigen::Vector3d>& points,
                 const std::vector<Eigen::Isometry3d>& symmetries) {
  auto max_distance = [&](const Eigen::Isometry3d& t) {
    double worst = 0;
    for (const Eigen::Vector3d& x : points) {
      worst = std::max(worst, (estimate * x - t * x).squaredNorm());
    }
    return std::sqrt(worst);
  };
  double best = max_distance(truth);
  for (const Eigen::Isometry3d& S : symmetries) best = std::min(best, max_distance(truth * S));
  return best;
}

double MssdRecall::Average() const {
  if (truths == 0) return 0;
  double sum = 0;
  for (int m : matched) sum += static_cast<double>(m) / truths;
  return sum / kThresholds;
}

void AddMssdScene(const std::vector<TruthObject>& truths,
                  const std::vector<v1::Instance>& instances,
                  const std::map<int, dataset::ModelInfo>& models,
                  const std::map<int, std::vector<Eigen::Vector3d>>& points, MssdRecall* recall) {
  recall->truths += static_cast<int>(truths.size());
  // error[i][t]: instance i against truth t (infinite across objects or without a model).
  const double kNever = std::numeric_limits<double>::infinity();
  std::vector<std::vector<double>> error(instances.size(),
                                         std::vector<double>(truths.size(), kNever));
  std::vector<double> diameter(truths.size(), 0);
  static const std::vector<Eigen::Isometry3d> kNone;
  for (size_t t = 0; t < truths.size(); ++t) {
    auto model = models.find(truths[t].obj_id);
    auto p = points.find(truths[t].obj_id);
    if (model == models.end() || p == points.end() || p->second.empty()) continue;
    diameter[t] = model->second.diameter;
    for (size_t i = 0; i < instances.size(); ++i) {
      if (instances[i].obj_id() != truths[t].obj_id) continue;
      error[i][t] = MssdError(InstancePose(instances[i]), truths[t].pose, p->second,
                              model->second.symmetries);
    }
  }
  std::vector<size_t> order(instances.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t a, size_t b) { return instances[a].score() > instances[b].score(); });
  for (int k = 0; k < MssdRecall::kThresholds; ++k) {
    const double fraction = 0.05 * (k + 1);
    std::vector<bool> taken(truths.size(), false);
    for (size_t i : order) {
      int best = -1;
      for (size_t t = 0; t < truths.size(); ++t) {
        if (taken[t] || !(error[i][t] < fraction * diameter[t])) continue;
        if (best < 0 || error[i][t] < error[i][best]) best = static_cast<int>(t);
      }
      if (best < 0) continue;
      taken[best] = true;
      ++recall->matched[k];
    }
  }
}

}  // namespace skimap::client
