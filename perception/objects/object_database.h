// ObjectDatabase: the trained knowledge of the offline pipeline (paper §3) — the objects'
// descriptor-voxel models (centroids), the class stack and the random forest — and the
// descriptor -> (object, voxel) classification with verification used online.
//
//   absl::StatusOr<ObjectDatabase> db = TrainObjectDatabase(dataset_root, params);  // training.h
//   std::vector<Prediction> p;
//   db->Classify(descriptor, features_scratch, &p);  // forest top-n, each verified
//
// Verification (paper §3.1, Fig. 4): a prediction is kept only if the descriptor lies
// within params.verify_threshold of one of the centroids of the predicted voxel v(c)
// (Hamming bits for binary descriptors, L2 for float ones).
//
// Persistence: server/core/objects/object_database_io.h (SQLite, storage/object_store.h).
// Thread safety: immutable after construction; every const method may run concurrently.
#ifndef SKIMAP_PERCEPTION_OBJECTS_OBJECT_DATABASE_H_
#define SKIMAP_PERCEPTION_OBJECTS_OBJECT_DATABASE_H_

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "perception/objects/class_stack.h"
#include "perception/objects/features.h"
#include "perception/objects/mean_shift.h"
#include "perception/objects/object_model.h"
#include "perception/objects/random_forest.h"

namespace skimap::objects {

// The thresholds a map applies before it lists an instance recognised with this database
// (docs/recognition.md, "Global instances") where the map's own options leave them unset:
// calibrated per detector on validation renders (DefaultInstanceThresholds). < 0: the
// detector's.
struct InstanceThresholds {
  double min_score = -1;          // >= 0, at the reference surface (scaled by an object's)
  double min_fit = -1;            // in [0, 1]
  double max_view_conflict = -1;  // in [0, 1]
  friend bool operator==(const InstanceThresholds&, const InstanceThresholds&) = default;
};

// Each detector's instance thresholds: SIFT's and ORB's chosen on the validation renders
// (docs/recognition.md); AKAZE and BRISK, not calibrated, take ORB's (binary descriptors
// like it). REQUIRES: a canonical detector name (CanonicalDetectorName).
InstanceThresholds DefaultInstanceThresholds(const std::string& detector);

// Everything that shapes a database; stored with it (training parameters table).
struct ObjectDatabaseParams {
  FeatureOptions features;                      // detector name and features per image
  double resolution = 0.01;                     // descriptor-voxel edge, metres, in [0.001, 1]
  MeanShiftOptions mean_shift{.bandwidth = 0};  // bandwidth <= 0: the detector's default
  int classes_per_object = 300;                 // k, >= 1
  ForestOptions forest;                         // trees x depth (paper: 24 x 24)
  int max_samples_per_class = 0;                // forest training samples per class; 0 = all
  double verify_threshold = 0;                  // <= 0: the detector's default (docs/objects.md)
  int top_n = 3;                                // forest candidates verified per descriptor, >= 1
  int mask_erosion_px = 2;                      // training masks are eroded by this much, 0..32
  int rgb_stride_px = 2;  // every n-th pixel (both axes) feeds the RGB volume, >= 1
  // Synthetic zoom-outs: each training view is also described shrunk by sqrt(2), 2, ...
  // up to this factor (1 = off, at most 8), so that the forest knows an object's features
  // as a camera sees them from that many times the training distance (docs/objects.md).
  double zoom_out = 4;
  InstanceThresholds instances;  // what maps recognising with the database list
  friend bool operator==(const ObjectDatabaseParams&, const ObjectDatabaseParams&) = default;
};

// Replaces "default" (<= 0) bandwidth / verify_threshold and (< 0) instance thresholds with
// the detector's values and validates every field; InvalidArgument naming the field.
absl::StatusOr<ObjectDatabaseParams> ResolveParams(const ObjectDatabaseParams& params);

// One classification candidate.
struct Prediction {
  uint32_t cls = 0;                // c = object_index * k + rank
  int object_index = -1;           // o(v(c))
  int obj_id = 0;                  // the object's dataset id
  int rank = -1;                   // j: the voxel in the object's evidence order
  Eigen::Vector3d point{0, 0, 0};  // v(c): the voxel centre in the object frame, metres
  float confidence = 0;            // forest confidence in [0, 1]
  float distance = 0;              // to the nearest centroid of v(c) (bits or L2)
  bool verified = false;           // distance <= verify_threshold
};

class ObjectDatabase {
 public:
  ObjectDatabase() = default;
  // Assembles a database, checking consistency: params resolved and valid, unique obj_ids,
  // layouts, the class stack matching the objects, the forest's dims and class count.
  static absl::StatusOr<ObjectDatabase> Create(ObjectDatabaseParams params,
                                               std::vector<ObjectModel> objects,
                                               RandomForest forest);

  const ObjectDatabaseParams& params() const { return params_; }
  const DescriptorLayout& layout() const { return layout_; }
  const std::vector<ObjectModel>& objects() const { return objects_; }
  const ClassStack& stack() const { return stack_; }
  const RandomForest& forest() const { return forest_; }
  // Index of the object with this dataset id, or -1.
  int FindObject(int obj_id) const;

  // The voxel of class c (REQUIRES: stack().Valid(c)).
  const VoxelModel& VoxelOfClass(uint32_t c) const;
  // Distance from d to the nearest centroid of v(c) (REQUIRES: stack().Valid(c)).
  float NearestCentroidDistance(uint32_t c, DescriptorRef d) const;

  // The forest's top params.top_n classes for descriptor d, each with its verification,
  // highest confidence first. `features` is scratch (resized as needed).
  void Classify(DescriptorRef d, std::vector<float>* features, std::vector<Prediction>* out) const;
  // Classify for every row of `descriptors` at once (the forest's PredictMany): out[i] holds
  // row i's candidates, as Classify gives them.
  void ClassifyMany(const DescriptorMatrix& descriptors,
                    std::vector<std::vector<Prediction>>* out) const;
  // The most confident verified candidate; false if none verifies.
  bool Recognize(DescriptorRef d, std::vector<float>* features, Prediction* out) const;

  // Payload bytes: centroids + cardinalities, forest, RGB volumes.
  size_t ModelBytes() const;

  friend bool operator==(const ObjectDatabase&, const ObjectDatabase&) = default;

 private:
  // The candidates `scores` of descriptor d as predictions, each verified.
  void Verify(DescriptorRef d, const std::vector<ClassScore>& scores,
              std::vector<Prediction>* out) const;

  ObjectDatabaseParams params_;
  DescriptorLayout layout_;
  std::vector<ObjectModel> objects_;
  ClassStack stack_;
  RandomForest forest_;
};

}  // namespace skimap::objects

#endif  // SKIMAP_PERCEPTION_OBJECTS_OBJECT_DATABASE_H_
