// The single-view baseline of `skimap eval` (issue: "multi-view beats single view"): each
// frame alone, with the same features and object database as the map's recognition —
// the server's ClassifyImage with return_matches gives the frame's 2D-3D matches (keypoint,
// the predicted class's voxel centre in the model frame) — and per object a PnP RANSAC
// pose. Over a scene, each object keeps its best view (the most PnP inliers): one
// estimate per object, scored exactly as the map's instances are (client/cli/pose_score.h).
//
//   SingleViewScene scene;
//   for (each frame) scene.Add(EstimateSingleViewPoses(response.matches(), frame.K, {}),
//                              frame.T_wc);
//   ScoreScene(truths, scene.Instances(), models, score_options);
//
// PnP (OpenCV): USAC over the object's matches (minimal samples, MSAC score, inner local
// optimisation, a fixed random state: the answer is a function of the input), reprojection
// threshold reprojection_px, then Levenberg-Marquardt on the inliers; a pose needs
// min_inliers inliers and the object in front of the camera (0.05 m < z < 10 m).
//
// Thread safety: pure functions; a SingleViewScene is not thread safe.
#ifndef CLIENT_CLI_SINGLE_VIEW_H_
#define CLIENT_CLI_SINGLE_VIEW_H_

#include <map>
#include <vector>

#include "Eigen/Geometry"
#include "dataset/types.h"
#include "skimap/v1/instances.pb.h"
#include "skimap/v1/objects.pb.h"

namespace skimap::client {

struct SingleViewOptions {
  int min_inliers = 8;         // the paper's hypotheses need 3 matches; PnP wants more
  double reprojection_px = 8;  // voxel centres (1 cm) seen at 1 m are ~5 px off a keypoint
  int iterations = 10000;      // ~15 % inliers: P(4 inliers) = 5e-4, so 99 % needs ~9000
};

struct SingleViewPose {
  int obj_id = 0;
  Eigen::Isometry3d T_cm = Eigen::Isometry3d::Identity();  // camera <- model
  int inliers = 0, matches = 0;
};

// One pose per object with at least min_inliers inliers, most inliers first.
std::vector<SingleViewPose> EstimateSingleViewPoses(
    const google::protobuf::RepeatedPtrField<v1::FeatureMatch>& matches,
    const dataset::Intrinsics& K, const SingleViewOptions& options);

// A scene's single-view answer: per object the pose of its best frame, in the world frame.
class SingleViewScene {
 public:
  void Add(const std::vector<SingleViewPose>& poses, const Eigen::Isometry3d& T_wc);
  // One instance per object seen (id = obj_id, score = inliers), by obj_id.
  std::vector<v1::Instance> Instances() const;

 private:
  struct Best {
    Eigen::Isometry3d T_wm;
    int inliers = 0;
  };
  std::map<int, Best> best_;
};

}  // namespace skimap::client

#endif  // CLIENT_CLI_SINGLE_VIEW_H_
