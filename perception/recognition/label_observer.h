// Label observations (paper §4.1): the sparse 2D features of a frame classified by the
// object database's forest and verified against the predicted voxel's centroids, each
// back-projected with its depth into the camera frame. Fused into the map's Labels volume
// (MultiLabelVoxel) at the world point they land on:
//
//   LabelObserver observer(model);
//   absl::StatusOr<LabelObservations> obs = observer.Observe(frame, {0.1, 5});
//   AddLabels(*obs, frame.pose, labels_grid, &batch);   // +1 of class c at each point
//
// Observations are in the camera frame, so they do not depend on the pose: UpdatePoses
// moves a frame's labels by subtracting AddLabels with the old pose and adding them with
// the new one. Observe is deterministic for a frame and a database.
//
// Thread safety: a LabelObserver is not thread safe (OpenCV detectors keep state); use
// one per thread. AddLabels is pure.
#ifndef PERCEPTION_RECOGNITION_LABEL_OBSERVER_H_
#define PERCEPTION_RECOGNITION_LABEL_OBSERVER_H_

#include <cstdint>
#include <memory>
#include <vector>

#include "Eigen/Core"
#include "absl/status/statusor.h"
#include "perception/objects/features.h"
#include "perception/recognition/recognition_model.h"
#include "perception/rgbd_frame.h"
#include "skimap/grid.h"
#include "skimap/label_voxel.h"
#include "skimap/voxel_batch.h"

namespace skimap::recognition {

struct LabelObservation {
  Eigen::Vector3f point;  // camera frame, metres
  uint32_t cls = 0;       // c = o * k + j
  float confidence = 0;   // forest confidence in [0, 1]
};

struct LabelObservations {
  std::vector<LabelObservation> labels;
  int features = 0;    // keypoints detected
  int with_depth = 0;  // ... with a depth in range at their pixel
  int verified = 0;    // ... with a verified candidate of a wanted object (= labels.size())
};

class LabelObserver {
 public:
  // REQUIRES: model outlives the observer.
  explicit LabelObserver(const RecognitionModel& model);
  ~LabelObserver();

  // Detects the database's features on the frame's colour image (none: no labels), keeps
  // keypoints whose depth pixel (at the rounded position, as in training) lies in
  // [min_depth, max_depth], and labels each with its most confident verified class when
  // that class belongs to a wanted object. Errors: the detector's.
  absl::StatusOr<LabelObservations> Observe(const perception::RgbdFrame& frame, double min_depth,
                                            double max_depth);

 private:
  const RecognitionModel& model_;
  std::unique_ptr<objects::FeatureExtractor> extractor_;
  std::vector<std::vector<objects::Prediction>> predictions_;  // per kept keypoint
};

// Adds one MultiLabelVoxel(cls, 1) per observation at pose * point (labels grid keys).
// Points without a key are dropped.
void AddLabels(const LabelObservations& observations, const perception::CameraPose& pose,
               const Grid& grid, VoxelBatch<MultiLabelVoxel>* batch);

}  // namespace skimap::recognition

#endif  // PERCEPTION_RECOGNITION_LABEL_OBSERVER_H_
