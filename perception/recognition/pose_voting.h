// Local hypotheses (paper §4.2): 6-DOF poses of one object from its label matches inside
// the active sphere, by 3-point RANSAC and 3D Hough voting for the object's base point.
//
//   std::vector<PoseEstimate> h = VotePoses(matches, model.object(o), sphere, options, rng);
//
// A match pairs a Labels-volume voxel (its centre p, world frame) with the model-frame
// centre v of the voxel its label's class stands for (Eq. 8), weighted by the label's
// count. Each of `triples` random triples (the first match drawn with probability
// proportional to the weights, the other two uniformly among the matches within the
// object's diameter of it in the world) that passes the geometric checks — every pair as far apart
// in the world as in the model (within `consistency`), sides at least `min_side`, not collinear —
// gives a rigid transform (least squares, fit_rigid below), which votes for the bin of the 3D Hough
// grid (edge `bin`, over the sphere) holding the transformed base point. The base, not the
// centroid, makes a false triple whose centroid lands near the true one vote elsewhere (Fig. 7).
// Bins with at least `min_votes` votes in their 3x3x3 neighbourhood are peaks (the best
// `max_peaks`, no two adjacent); a peak's transforms (its bin and the 26 around it; at most 24,
// evenly taken) are scored by their inlier matches (p within `inlier_distance` of T·v, weights
// summed), the best is refit on its inliers (RefinePose), and kept when its score reaches
// `min_score`.
//
// Thread safety: pure functions (the caller's rng aside).
#ifndef PERCEPTION_RECOGNITION_POSE_VOTING_H_
#define PERCEPTION_RECOGNITION_POSE_VOTING_H_

#include <random>
#include <span>
#include <vector>

#include "Eigen/Geometry"
#include "perception/recognition/recognition_model.h"

namespace skimap::recognition {

struct LabelMatch {
  Eigen::Vector3f world;  // p: the labels voxel's centre, world frame
  Eigen::Vector3f model;  // v: the class's voxel centre, model frame
  float weight = 1;       // the label's count in the voxel
};

struct Sphere {
  Eigen::Vector3f centre = Eigen::Vector3f::Zero();  // world, metres
  float radius = 0;
};

struct VotingOptions {
  int triples = 400;              // m random triples per object
  float bin = 0.02f;              // Hough bin edge, metres
  float consistency = 0.03f;      // |world distance - model distance| per pair, metres
  float min_side = 0.02f;         // shortest triangle side (and height / 2), metres
  float inlier_distance = 0.02f;  // |T v - p| of an inlier, metres
  int min_votes = 3;              // a peak's votes
  int max_peaks = 3;              // hypotheses per object and frame at most
  float min_score = 4;            // inlier weight of a kept hypothesis
};

struct PoseEstimate {
  Eigen::Isometry3f pose = Eigen::Isometry3f::Identity();  // world <- model
  float score = 0;                                         // summed weight of the inlier matches
  int inliers = 0;                                         // inlier matches
  int votes = 0;  // Hough votes of its peak (0 when not from voting)
};

// Least-squares rigid transform (rotation + translation, no scale) taking model[i] to
// world[i] (Umeyama). REQUIRES: n >= 3 points, not all collinear.
Eigen::Isometry3f FitRigid(std::span<const LabelMatch> matches);

// Least-squares rigid transform with a weight per match (weighted Kabsch); identity when
// the weights sum to zero.
Eigen::Isometry3f FitRigidWeighted(std::span<const LabelMatch> matches,
                                   std::span<const float> weights);

// The inliers of `pose` among `matches` (within `distance`), refit on them, twice; then
// iteratively reweighted refits (Gaussian weights, sigma = distance / 2) while they fit
// the matches tighter.
PoseEstimate RefinePose(std::span<const LabelMatch> matches, const Eigen::Isometry3f& pose,
                        float distance);

// The object's local hypotheses from its matches (all of one object), strongest first.
std::vector<PoseEstimate> VotePoses(std::span<const LabelMatch> matches, const ObjectShape& shape,
                                    const Sphere& sphere, const VotingOptions& options,
                                    std::mt19937_64& rng);

}  // namespace skimap::recognition

#endif  // PERCEPTION_RECOGNITION_POSE_VOTING_H_
