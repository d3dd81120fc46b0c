#include "server/core/recognition/recognition_config.h"

#include <cmath>

#include "absl/container/flat_hash_set.h"
#include "absl/strings/str_cat.h"
#include "perception/objects/object_database.h"

namespace skimap::server {
namespace {

absl::Status BadRecognitionOption(absl::string_view field, absl::string_view what) {
  return absl::InvalidArgumentError(absl::StrCat("options.recognition.", field, " ", what));
}

// `value` (when set) must lie in [lo, hi].
absl::Status Range(bool has, double value, double lo, double hi, absl::string_view field,
                   double* out) {
  if (!has) return absl::OkStatus();
  if (!(value >= lo && value <= hi)) {
    return BadRecognitionOption(field, absl::StrCat("must be in [", lo, ", ", hi, "] metres"));
  }
  *out = value;
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<RecognitionConfig> ResolveRecognitionOptions(const v1::RecognitionOptions& o) {
  RecognitionConfig c;
  c.enabled = o.enabled();
  absl::flat_hash_set<int> seen;
  for (int i = 0; i < o.obj_ids_size(); ++i) {
    if (o.obj_ids(i) <= 0 || !seen.insert(o.obj_ids(i)).second) {
      return BadRecognitionOption(
          absl::StrCat("obj_ids[", i, "]"),
          absl::StrCat("must be a positive object id listed once, got ", o.obj_ids(i)));
    }
    c.obj_ids.push_back(o.obj_ids(i));
  }
  for (absl::Status s : {
           Range(o.has_labels_resolution(), o.labels_resolution(), 0.002, 0.1, "labels_resolution",
                 &c.labels_resolution),
           Range(o.has_hypotheses_resolution(), o.hypotheses_resolution(), 0.005, 0.5,
                 "hypotheses_resolution", &c.hypotheses_resolution),
           Range(o.has_instances_resolution(), o.instances_resolution(), 0.01, 1,
                 "instances_resolution", &c.instances_resolution),
           Range(o.has_sphere_distance(), o.sphere_distance(), 0, 10, "sphere_distance",
                 &c.sphere_distance),
           Range(o.has_sphere_radius(), o.sphere_radius(), 0.05, 5, "sphere_radius",
                 &c.sphere_radius),
           Range(o.has_hough_bin(), o.hough_bin(), 0.002, 0.5, "hough_bin", &c.hough_bin),
       }) {
    if (!s.ok()) return s;
  }
  if (o.has_triples()) {
    if (o.triples() < 10 || o.triples() > 100000)
      return BadRecognitionOption("triples", "must be in 10..100000");
    c.triples = static_cast<int>(o.triples());
  }
  if (o.has_min_instance_score()) {
    if (!(o.min_instance_score() >= 0) || !std::isfinite(o.min_instance_score())) {
      return BadRecognitionOption("min_instance_score", "must be finite and >= 0");
    }
    c.visible.min_score = o.min_instance_score();
  }
  if (o.has_min_instance_fit()) {
    if (!(o.min_instance_fit() >= 0 && o.min_instance_fit() <= 1)) {
      return BadRecognitionOption("min_instance_fit", "must be in [0, 1]");
    }
    c.visible.min_fit = o.min_instance_fit();
  }
  if (o.has_max_view_conflict()) {
    if (!(o.max_view_conflict() >= 0 && o.max_view_conflict() <= 1)) {
      return BadRecognitionOption("max_view_conflict", "must be in [0, 1]");
    }
    c.visible.max_view_conflict = o.max_view_conflict();
  }
  switch (o.policy()) {
    case v1::RecognitionOptions::POLICY_UNSPECIFIED:
    case v1::RecognitionOptions::NEWEST:
      break;
    case v1::RecognitionOptions::EVERY_FRAME:
      c.every_frame = true;
      break;
    default:
      return BadRecognitionOption("policy", absl::StrCat("unknown value ", o.policy()));
  }
  return c;
}

v1::RecognitionOptions ToProto(const RecognitionConfig& c) {
  v1::RecognitionOptions o;
  o.set_enabled(c.enabled);
  for (int id : c.obj_ids) o.add_obj_ids(id);
  o.set_labels_resolution(c.labels_resolution);
  o.set_hypotheses_resolution(c.hypotheses_resolution);
  o.set_instances_resolution(c.instances_resolution);
  o.set_sphere_distance(c.sphere_distance);
  o.set_sphere_radius(c.sphere_radius);
  o.set_triples(static_cast<uint32_t>(c.triples));
  o.set_hough_bin(c.hough_bin);
  o.set_policy(c.every_frame ? v1::RecognitionOptions::EVERY_FRAME
                             : v1::RecognitionOptions::NEWEST);
  if (c.visible.min_score.has_value()) o.set_min_instance_score(*c.visible.min_score);
  if (c.visible.min_fit.has_value()) o.set_min_instance_fit(*c.visible.min_fit);
  if (c.visible.max_view_conflict.has_value())
    o.set_max_view_conflict(*c.visible.max_view_conflict);
  return o;
}

InstanceVisibility VisibilityOptions::Resolve(const objects::InstanceThresholds* classifier) const {
  const objects::InstanceThresholds t =
      classifier != nullptr
          ? *classifier
          : objects::DefaultInstanceThresholds(objects::FeatureOptions{}.detector);
  return {.min_score = min_score.value_or(t.min_score),
          .min_fit = min_fit.value_or(t.min_fit),
          .max_view_conflict = max_view_conflict.value_or(t.max_view_conflict)};
}

}  // namespace skimap::server
