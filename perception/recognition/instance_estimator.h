// Global instance retrieval (paper §4.3): one object's hypotheses around a place become
// instance estimates. Hypotheses are grouped by position (each group: the hypotheses within
// `radius` of its strongest one, strongest first); in each group the orientations are
// clustered (Fig. 8): the hypothesis with the most score within `max_angle` of it is the
// cluster's centre, the cluster those within `max_angle` of the centre. The estimate's
// orientation is the cluster's mean rotation (sign-aligned quaternions, normalised: the
// chordal L2 mean), its position the mean of the members' positions (as the paper does),
// both weighted by score. Groups whose cluster has fewer than `min_support` hypotheses or
// hypotheses from fewer than `min_frames` frames give no estimate.
//
// Thread safety: pure function.
#ifndef PERCEPTION_RECOGNITION_INSTANCE_ESTIMATOR_H_
#define PERCEPTION_RECOGNITION_INSTANCE_ESTIMATOR_H_

#include <cstdint>
#include <span>
#include <vector>

#include "Eigen/Geometry"

namespace skimap::recognition {

struct HypothesisSample {
  Eigen::Vector3f t = Eigen::Vector3f::Zero();  // world <- model translation, metres
  Eigen::Quaternionf q = Eigen::Quaternionf::Identity();
  float score = 0;
  uint64_t frame = 0;
};

struct ClusterOptions {
  float radius = 0.04f;      // metres: a position group's extent around its seed
  float max_angle = 0.175f;  // radians (10 degrees): the orientation cluster's radius
  int min_support = 3;
  int min_frames = 2;
};

struct InstanceEstimate {
  Eigen::Vector3f t = Eigen::Vector3f::Zero();
  Eigen::Quaternionf q = Eigen::Quaternionf::Identity();
  float score = 0;                           // summed score of the cluster's hypotheses
  int support = 0;                           // hypotheses in the cluster
  int frames = 0;                            // distinct frames among them
  uint64_t first_frame = 0, last_frame = 0;  // smallest and largest of those frames
  float spread_t = 0;                        // RMS distance of the members to t, metres
  float spread_r = 0;                        // RMS angle of the members to q, radians
  float fit = 0;  // set by the caller's verification against the map (0 here)
};

// Angle between two rotations, radians in [0, pi].
float RotationAngle(const Eigen::Quaternionf& a, const Eigen::Quaternionf& b);

// Estimates from one object's hypotheses, strongest (score) first.
std::vector<InstanceEstimate> EstimateInstances(std::span<const HypothesisSample> hypotheses,
                                                const ClusterOptions& options);

}  // namespace skimap::recognition

#endif  // PERCEPTION_RECOGNITION_INSTANCE_ESTIMATOR_H_
