// ObjectTrainer: fuses one object's training frames (RGB-D + object pose + visible mask)
// into its Descriptor Voxel volume and RGB volume, both SkiMaps in the object frame
// (paper §3, Fig. 3 a-b), then reduces every descriptor voxel with mean shift.
//
//   auto trainer = ObjectTrainer::Create(obj_id, "cereal", resolved_params);
//   for (frame : orbit) RETURN_IF_ERROR((*trainer)->AddFrame(frame).status());
//   absl::StatusOr<TrainedObject> t = (*trainer)->Finish();
//
// Per frame: features are detected inside the (eroded) mask; each keypoint with valid
// depth is back-projected (pinhole, pixel centres at integer coordinates), mapped to the
// object frame with inv(T_m2c) and fused into the voxel holding it. With params.zoom_out
// > 1 the same is done on the view shrunk by sqrt(2), 2, ... up to zoom_out (the object as
// seen from farther away). Masked depth pixels (every rgb_stride_px-th, full view only)
// feed the RGB volume.
//
// Thread safety: not thread safe (one trainer per object; trainers of different objects
// may run concurrently).
#ifndef SKIMAP_PERCEPTION_OBJECTS_OBJECT_TRAINER_H_
#define SKIMAP_PERCEPTION_OBJECTS_OBJECT_TRAINER_H_

#include <Eigen/Geometry>
#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "dataset/types.h"
#include "perception/objects/descriptor_voxel.h"
#include "perception/objects/features.h"
#include "perception/objects/object_database.h"
#include "perception/objects/object_model.h"
#include "skimap/skimap.h"

namespace skimap::objects {

// One training view of one object.
struct TrainingFrame {
  cv::Mat bgr;               // CV_8UC3
  cv::Mat depth;             // CV_16UC1 raw (* depth_scale = mm) or CV_32FC1 metres
  double depth_scale = 1.0;  // mm per raw unit (CV_16UC1 only), > 0
  dataset::Intrinsics K;     // fx, fy > 0
  Eigen::Isometry3d T_m2c = Eigen::Isometry3d::Identity();  // model -> camera, metres
  cv::Mat mask;  // CV_8UC1, non-zero where the object is visible
};

// What one frame contributed.
struct FrameContribution {
  int keypoints = 0;    // detected inside the mask
  int descriptors = 0;  // fused (keypoint had valid depth)
  // Both count the zoom-outs' keypoints too.
};

// A trained object: its model plus the raw descriptors of every voxel (same order as
// model.voxels), which the forest trains on.
struct TrainedObject {
  ObjectModel model;
  std::vector<DescriptorMatrix> raw;
};

class ObjectTrainer {
 public:
  // REQUIRES: params resolved (ResolveParams); InvalidArgument otherwise.
  static absl::StatusOr<std::unique_ptr<ObjectTrainer>> Create(int obj_id, std::string name,
                                                               const ObjectDatabaseParams& params);

  // Fuses one frame. InvalidArgument naming the field: "bgr" (missing / wrong type),
  // "depth" (missing, wrong type or size), "mask" (missing, wrong size, or empty: the
  // object is not visible), "K", "depth_scale", "T_m2c" (not finite). A frame in which no
  // keypoint has depth is not an error (it contributes nothing).
  absl::StatusOr<FrameContribution> AddFrame(const TrainingFrame& frame);

  // Descriptors fused so far and their payload bytes (the raw Descriptor Matrices).
  const ObjectTrainingStats& stats() const { return stats_; }
  // The descriptor volume (object frame).
  const SkiMap<DescriptorVoxel>& descriptor_volume() const { return *descriptors_; }

  // Runs mean shift on every voxel (on `threads` threads) and returns the model; the
  // trainer stays usable (more frames may be added and Finish called again).
  // FailedPrecondition if no descriptor was fused.
  absl::StatusOr<TrainedObject> Finish(int threads = 1) const;

 private:
  // Detects features of `f` inside `mask` and fuses the ones with depth; adds to *out.
  absl::Status AddDescriptors(const TrainingFrame& f, const cv::Mat& mask, FrameContribution* out);
  ObjectTrainer(int obj_id, std::string name, const ObjectDatabaseParams& params,
                std::unique_ptr<FeatureExtractor> extractor);

  const int obj_id_;
  const std::string name_;
  const ObjectDatabaseParams params_;
  std::unique_ptr<FeatureExtractor> extractor_;
  std::unique_ptr<SkiMap<DescriptorVoxel>> descriptors_;
  std::unique_ptr<SkiMap<RGBWeightedVoxel>> rgb_;
  ObjectTrainingStats stats_;
};

}  // namespace skimap::objects

#endif  // SKIMAP_PERCEPTION_OBJECTS_OBJECT_TRAINER_H_
