// Scoring recognised instances against a dataset's ground truth (what `skimap eval`
// reports): an instance is a true positive for a ground-truth object when it names the same
// object and its pose is within max_translation and max_rotation_deg of the truth or of a
// symmetric equivalent (truth * S for the model's symmetries S, BOP convention). Each truth
// and each instance is matched at most once (greedily, the closest first).
//
// Beside it, BOP's stricter MSSD recall (Hodan et al., BOP challenge 2019-2023): the error
// of an estimate is the maximum symmetry-aware surface distance over the model's points,
// min over S of max over x of |estimate * x - truth * S * x|; per threshold
// theta in {0.05, 0.10, ..., 0.50} x the object's diameter, estimates (highest score
// first) are matched to the closest unmatched truth of the same object within theta; the
// recall is the mean over the thresholds of the fraction of truths matched (AR_MSSD).
//
// Thread safety: pure functions.
#ifndef CLIENT_CLI_POSE_SCORE_H_
#define CLIENT_CLI_POSE_SCORE_H_

#include <map>
#include <vector>

#include "Eigen/Geometry"
#include "dataset/types.h"
#include "skimap/v1/instances.pb.h"

namespace skimap::client {

struct TruthObject {
  int obj_id = 0;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();  // world <- model
};

struct ScoreOptions {
  double max_translation = 0.03;  // metres
  double max_rotation_deg = 10;
};

// Translation (metres) and rotation (degrees) error of `estimate` against `truth`, the
// smallest over truth * S for S in {identity} + `symmetries`.
struct PoseError {
  double translation = 0;
  double rotation_deg = 0;
};
PoseError ErrorUnderSymmetries(const Eigen::Isometry3d& estimate, const Eigen::Isometry3d& truth,
                               const std::vector<Eigen::Isometry3d>& symmetries);

// The instance's pose as an isometry (world <- model).
Eigen::Isometry3d InstancePose(const v1::Instance& instance);

struct SceneScore {
  int truths = 0, instances = 0, true_positives = 0;
  // Per truth (in order): the matched instance's index, or -1; and its error when matched.
  std::vector<int> match;
  std::vector<PoseError> error;
};

// `models` by obj_id gives the symmetries (an object missing from it has none).
SceneScore ScoreScene(const std::vector<TruthObject>& truths,
                      const std::vector<v1::Instance>& instances,
                      const std::map<int, dataset::ModelInfo>& models, const ScoreOptions& options);

// The MSSD error (metres) of `estimate` against `truth` over `points` (model frame).
// REQUIRES: points non-empty.
double MssdError(const Eigen::Isometry3d& estimate, const Eigen::Isometry3d& truth,
                 const std::vector<Eigen::Vector3d>& points,
                 const std::vector<Eigen::Isometry3d>& symmetries);

// Truths matched per MSSD threshold, summed over scenes.
struct MssdRecall {
  static constexpr int kThresholds = 10;  // theta_i = 0.05 * (i + 1) x diameter
  int truths = 0;
  int matched[kThresholds] = {};
  // AR_MSSD: the mean over the thresholds of matched / truths (0 without truths).
  double Average() const;
};

// Adds one scene to `recall`. `points` by obj_id: the model's points (metres); a truth
// whose object has no points or no diameter in `models` counts as a truth never matched.
void AddMssdScene(const std::vector<TruthObject>& truths,
                  const std::vector<v1::Instance>& instances,
                  const std::map<int, dataset::ModelInfo>& models,
                  const std::map<int, std::vector<Eigen::Vector3d>>& points, MssdRecall* recall);

}  // namespace skimap::client

#endif  // CLIENT_CLI_POSE_SCORE_H_
