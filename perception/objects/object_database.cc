#include "perception/objects/object_database.h"

#include <algorithm>
#include <cmath>
#include <set>

#include "absl/strings/str_cat.h"

namespace skimap::objects {
namespace {

absl::Status Bad(const char* field, double value, const char* want) {
  return absl::InvalidArgumentError(absl::StrCat(field, ": ", value, " must be ", want));
}

// Defaults per descriptor, measured on the sim objects (docs/objects.md, "Parameters").
double DefaultBandwidth(const std::string& detector, const DescriptorLayout& l) {
  if (l.binary()) return 0.3 * l.dims;  // ORB: 77 of 256 bits
  return detector == "SIFT" ? 200.0 : 0.5;
}
double DefaultVerifyThreshold(const std::string& detector, const DescriptorLayout& l) {
  if (l.binary()) return 0.3 * l.dims;  // ORB: 77 of 256 bits
  return detector == "SIFT" ? 250.0 : 0.7;
}

}  // namespace

InstanceThresholds DefaultInstanceThresholds(const std::string& detector) {
  // SIFT: the plateau of F1 over the hand-held and robot validation renders (sk and robot
  // seed 2). ORB: the first point of the same sweep with precision >= 0.90 (0.912, recall
  // 0.413): its false instances score about twice SIFT's.
  if (detector == "SIFT") return {.min_score = 52, .min_fit = 0.3, .max_view_conflict = 0.1};
  return {.min_score = 112, .min_fit = 0.4, .max_view_conflict = 0.02};
}

absl::StatusOr<ObjectDatabaseParams> ResolveParams(const ObjectDatabaseParams& in) {
  ObjectDatabaseParams p = in;
  absl::StatusOr<std::string> name = CanonicalDetectorName(p.features.detector);
  if (!name.ok()) return name.status();
  p.features.detector = *name;
  if (p.features.max_features < 1 || p.features.max_features > 100000) {
    return Bad("max_features", p.features.max_features, "in 1..100000");
  }
  absl::StatusOr<DescriptorLayout> layout = DetectorLayout(*name);
  if (!layout.ok()) return layout.status();
  if (!(p.resolution >= 0.001 && p.resolution <= 1)) {
    return Bad("resolution", p.resolution, "in [0.001, 1] metres");
  }
  if (std::isnan(p.mean_shift.bandwidth)) return Bad("bandwidth", NAN, "a number");
  if (p.mean_shift.bandwidth <= 0) p.mean_shift.bandwidth = DefaultBandwidth(*name, *layout);
  if (absl::Status s = ValidateMeanShiftOptions(p.mean_shift); !s.ok()) return s;
  if (p.classes_per_object < 1 || p.classes_per_object > 100000) {
    return Bad("classes_per_object", p.classes_per_object, "in 1..100000");
  }
  if (absl::Status s = ValidateForestOptions(p.forest); !s.ok()) return s;
  if (p.max_samples_per_class < 0)
    return Bad("max_samples_per_class", p.max_samples_per_class, ">= 0");
  if (std::isnan(p.verify_threshold)) return Bad("verify_threshold", NAN, "a number");
  if (p.verify_threshold <= 0) p.verify_threshold = DefaultVerifyThreshold(*name, *layout);
  if (!std::isfinite(p.verify_threshold))
    return Bad("verify_threshold", p.verify_threshold, "finite");
  if (p.top_n < 1 || p.top_n > 64) return Bad("top_n", p.top_n, "in 1..64");
  if (p.mask_erosion_px < 0 || p.mask_erosion_px > 32) {
    return Bad("mask_erosion_px", p.mask_erosion_px, "in 0..32");
  }
  if (p.rgb_stride_px < 1 || p.rgb_stride_px > 64)
    return Bad("rgb_stride_px", p.rgb_stride_px, "in 1..64");
  if (!(p.zoom_out >= 1 && p.zoom_out <= 8)) return Bad("zoom_out", p.zoom_out, "in 1..8");
  InstanceThresholds& t = p.instances;
  const InstanceThresholds detector = DefaultInstanceThresholds(*name);
  if (t.min_score < 0) t.min_score = detector.min_score;
  if (t.min_fit < 0) t.min_fit = detector.min_fit;
  if (t.max_view_conflict < 0) t.max_view_conflict = detector.max_view_conflict;
  if (!(t.min_score >= 0 && std::isfinite(t.min_score))) {
    return Bad("min_instance_score", t.min_score, "finite and >= 0");
  }
  if (!(t.min_fit <= 1)) return Bad("min_instance_fit", t.min_fit, "in [0, 1]");
  if (!(t.max_view_conflict <= 1)) {
    return Bad("max_view_conflict", t.max_view_conflict, "in [0, 1]");
  }
  return p;
}

absl::StatusOr<ObjectDatabase> ObjectDatabase::Create(ObjectDatabaseParams params,
                                                      std::vector<ObjectModel> objects,
                                                      RandomForest forest) {
  absl::StatusOr<ObjectDatabaseParams> resolved = ResolveParams(params);
  if (!resolved.ok()) return resolved.status();
  if (!(*resolved == params)) {
    return absl::InvalidArgumentError("params: must be resolved (ResolveParams) before Create");
  }
  ObjectDatabase db;
  db.params_ = std::move(params);
  db.layout_ = *DetectorLayout(db.params_.features.detector);
  std::set<int> ids;
  std::vector<int> voxels;
  for (const ObjectModel& o : objects) {
    if (!ids.insert(o.obj_id).second) {
      return absl::InvalidArgumentError(absl::StrCat("obj_id: ", o.obj_id, " appears twice"));
    }
    for (const VoxelModel& v : o.voxels) {
      if (v.centroids.rows() != v.cardinalities.size() ||
          (!v.centroids.empty() && !(v.centroids.layout() == db.layout_))) {
        return absl::InvalidArgumentError(
            absl::StrCat("object ", o.obj_id, ": voxel centroids do not match the layout"));
      }
    }
    voxels.push_back(static_cast<int>(o.voxels.size()));
  }
  absl::StatusOr<ClassStack> stack = ClassStack::Create(db.params_.classes_per_object, voxels);
  if (!stack.ok()) return stack.status();
  if (forest.num_trees() > 0 &&
      (forest.dims() != db.layout_.FeatureDims() || forest.num_classes() != stack->num_classes())) {
    return absl::InvalidArgumentError(
        absl::StrCat("forest: ", forest.dims(), " features / ", forest.num_classes(),
                     " classes, want ", db.layout_.FeatureDims(), " / ", stack->num_classes()));
  }
  db.objects_ = std::move(objects);
  db.stack_ = *std::move(stack);
  db.forest_ = std::move(forest);
  return db;
}

int ObjectDatabase::FindObject(int obj_id) const {
  for (size_t i = 0; i < objects_.size(); ++i) {
    if (objects_[i].obj_id == obj_id) return static_cast<int>(i);
  }
  return -1;
}

const VoxelModel& ObjectDatabase::VoxelOfClass(uint32_t c) const {
  const StackedVoxel v = stack_.VoxelOf(c);
  return objects_[v.object_index].voxels[v.rank];
}

float ObjectDatabase::NearestCentroidDistance(uint32_t c, DescriptorRef d) const {
  const VoxelModel& v = VoxelOfClass(c);
  float best = INFINITY;
  for (size_t i = 0; i < v.centroids.rows(); ++i) {
    best = std::min(best, DescriptorDistance(layout_, v.centroids.Row(i), d));
  }
  return best;
}

void ObjectDatabase::Classify(DescriptorRef d, std::vector<float>* features,
                              std::vector<Prediction>* out) const {
  features->resize(layout_.FeatureDims());
  ToFeatures(layout_, d, *features);
  thread_local std::vector<ClassScore> scores;
  forest_.Predict(features->data(), params_.top_n, &scores);
  Verify(d, scores, out);
}

void ObjectDatabase::ClassifyMany(const DescriptorMatrix& descriptors,
                                  std::vector<std::vector<Prediction>>* out) const {
  const size_t n = descriptors.rows(), dims = layout_.FeatureDims();
  thread_local std::vector<std::vector<ClassScore>> scores;
  if (layout_.binary() && n > 0) {
    // Rows are packed back to back (DescriptorMatrix): the forest reads the bits.
    forest_.PredictManyBits(descriptors.Row(0).bits, dims / 8, n, params_.top_n, &scores);
  } else {
    thread_local std::vector<float> features;
    features.resize(n * dims);
    for (size_t i = 0; i < n; ++i) {
      ToFeatures(layout_, descriptors.Row(i), std::span<float>(features.data() + i * dims, dims));
    }
    forest_.PredictMany(features.data(), n, params_.top_n, &scores);
  }
  out->resize(n);
  for (size_t i = 0; i < n; ++i) Verify(descriptors.Row(i), scores[i], &(*out)[i]);
}

void ObjectDatabase::Verify(DescriptorRef d, const std::vector<ClassScore>& scores,
                            std::vector<Prediction>* out) const {
  out->clear();
  for (const ClassScore& s : scores) {
    if (!stack_.Valid(s.cls)) continue;
    Prediction p;
    p.cls = s.cls;
    const StackedVoxel v = stack_.VoxelOf(s.cls);
    p.object_index = v.object_index;
    p.rank = v.rank;
    p.obj_id = objects_[v.object_index].obj_id;
    p.point = VoxelCenter(objects_[v.object_index].voxels[v.rank].key, params_.resolution);
    p.confidence = s.confidence;
    p.distance = NearestCentroidDistance(s.cls, d);
    p.verified = p.distance <= params_.verify_threshold;
    out->push_back(p);
  }
}

bool ObjectDatabase::Recognize(DescriptorRef d, std::vector<float>* features,
                               Prediction* out) const {
  thread_local std::vector<Prediction> candidates;
  Classify(d, features, &candidates);
  for (const Prediction& p : candidates) {
    if (p.verified) {
      *out = p;
      return true;
    }
  }
  return false;
}

size_t ObjectDatabase::ModelBytes() const {
  size_t bytes = forest_.MemoryBytes();
  for (const ObjectModel& o : objects_) {
    bytes += o.rgb_volume.size();
    for (const VoxelModel& v : o.voxels) {
      bytes += v.centroids.PayloadBytes() + v.cardinalities.size() * sizeof(uint32_t);
    }
  }
  return bytes;
}

}  // namespace skimap::objects
