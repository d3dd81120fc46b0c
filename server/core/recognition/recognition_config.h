// RecognitionConfig: a map's effective recognition options (v1::RecognitionOptions with
// the defaults filled in and validated; docs/recognition.md explains each).
//
// Thread safety: plain values and pure functions.
#ifndef SERVER_CORE_RECOGNITION_RECOGNITION_CONFIG_H_
#define SERVER_CORE_RECOGNITION_RECOGNITION_CONFIG_H_

#include <cmath>
#include <optional>
#include <vector>

#include "absl/status/statusor.h"
#include "skimap/hypotheses_voxel.h"
#include "skimap/v1/instances.pb.h"

namespace skimap::objects {
struct InstanceThresholds;
}  // namespace skimap::objects

namespace skimap::server {

// The trained surface (m², 400 voxels of 1 cm) whose objects are asked min_score itself.
inline constexpr double kReferenceSurface = 0.04;

// When an instance is visible: listed, reported by events, found by GetInstance
// (docs/recognition.md, "Global instances"). The score asked grows with the square root of
// the object's trained surface: an object of surface A is asked
// min_score * sqrt(A / kReferenceSurface) (a 5 cm cube about 0.58 min_score), one of
// unknown surface (0) min_score.
struct InstanceVisibility {
  double min_score = 0;
  double min_fit = 0;
  double max_view_conflict = 1;
  double MinScore(double surface_area) const {
    return surface_area > 0 ? min_score * std::sqrt(surface_area / kReferenceSurface) : min_score;
  }
  bool operator()(const Instance& i, double surface_area) const {
    return i.score >= MinScore(surface_area) && i.fit >= min_fit &&
           ViewConflict(i) <= max_view_conflict;
  }
  friend bool operator==(const InstanceVisibility&, const InstanceVisibility&) = default;
};

// A map's own visibility thresholds (RecognitionOptions' min_instance_score,
// min_instance_fit, max_view_conflict). Each one unset is its classifier's: the thresholds
// stored with the object database, calibrated for its detector
// (objects::ObjectDatabaseParams::instances).
struct VisibilityOptions {
  std::optional<double> min_score, min_fit, max_view_conflict;
  // The thresholds in force under `classifier` (null: no classifier; the default
  // detector's).
  InstanceVisibility Resolve(const objects::InstanceThresholds* classifier) const;
  friend bool operator==(const VisibilityOptions&, const VisibilityOptions&) = default;
};

struct RecognitionConfig {
  bool enabled = false;
  std::vector<int> obj_ids;  // empty: every object of the classifier
  double labels_resolution = 0.005, hypotheses_resolution = 0.03, instances_resolution = 0.05;
  double sphere_distance = 0;  // metres along the optical axis; 0 = the scene rule
  double sphere_radius = 0.6;
  int triples = 2000;
  double hough_bin = 0.02;
  bool every_frame = false;   // policy EVERY_FRAME (else NEWEST)
  VisibilityOptions visible;  // min_instance_score, min_instance_fit, max_view_conflict
  friend bool operator==(const RecognitionConfig&, const RecognitionConfig&) = default;
};

// Defaults filled in and validated; InvalidArgument naming the field
// ("options.recognition.sphere_radius must be in [0.05, 5] metres").
absl::StatusOr<RecognitionConfig> ResolveRecognitionOptions(const v1::RecognitionOptions& o);
// Every field set (policy NEWEST or EVERY_FRAME) but the visibility thresholds the map
// leaves to its classifier.
v1::RecognitionOptions ToProto(const RecognitionConfig& c);

}  // namespace skimap::server

#endif  // SERVER_CORE_RECOGNITION_RECOGNITION_CONFIG_H_
