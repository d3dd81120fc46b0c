// Instance reconciliation (docs/recognition.md, "Choices", "Global instances"): brings a map's
// instances of one object in a region in line with the hypotheses there. It runs after a frame's
// hypotheses were added (region: the frame's active sphere) and after UpdatePoses moved
// hypotheses (region: around their old and new places).
//
//   1. The object's hypotheses near the region are clustered (instance_estimator.h).
//   2. Each estimate is refined against the Labels volume: the object's label matches
//      within its radius, inliers refit (pose_voting.h RefinePose); its score is their
//      weight. Estimates scoring under 3 are dropped.
//   3. Estimates are matched to the existing instances of the object nearest first, within
//      the match distance d = max(radius / 2, 3 cm): a match keeps its id (UPDATED). An
//      existing instance left without any hypothesis within d no longer has support: an
//      unmatched estimate takes it over (it moved: the id stays), else it is REMOVED when
//      it lies in the region. An unmatched estimate within d of a matched instance is a
//      duplicate and ignored; any other is a new instance (CREATED, the next id).
//   4. Two instances of the object closer than d are one: the younger is MERGED into the
//      older, which keeps its id. This includes an instance beyond the region that an
//      updated one moved next to.
//
// Events are about visible instances (ReconcileParams.visible): an instance becoming
// visible is CREATED, one falling below or going is REMOVED, a visible one that changed in
// any way (pose, score, support, sightings) is UPDATED: replaying the events gives exactly
// the listed instances.
//
// Thread safety: mutates `state`; REQUIRES the map's exclusive snapshot lock (the worker).
#ifndef SERVER_CORE_RECOGNITION_INSTANCE_RECONCILER_H_
#define SERVER_CORE_RECOGNITION_INSTANCE_RECONCILER_H_

#include <cstdint>
#include <span>
#include <string>

#include "perception/recognition/pose_voting.h"
#include "perception/recognition/recognition_model.h"
#include "server/core/maps/map_state.h"
#include "server/core/recognition/instance_checks.h"
#include "server/core/recognition/recognition_config.h"

namespace skimap::server {

struct ReconcileRequest {
  int object_index = 0;         // in the recognition model
  recognition::Sphere region;   // world
  uint64_t frame = 0;           // the frame that caused it (events, sightings)
  int64_t frame_time_us = 0;    // its timestamp
  bool frame_supports = false;  // the frame added hypotheses of this object (sightings)
  // The map's keyframes (view_keyframes.h): each instance updated here has its view counts
  // recounted over all of them at its new pose; none: the counts stay as they were.
  std::span<const ViewFrame> views;
};

struct ReconcileParams {
  std::string map_id;
  InstanceVisibility visible;
  float inlier_distance = 0.02f;
};

// Returns the number of events appended to state->recognition.log.
int ReconcileInstances(const recognition::RecognitionModel& model, const ReconcileParams& params,
                       const ReconcileRequest& request, MapState* state);

// Whether `instance` is visible under `visible`, its object's trained surface taken from
// `model` (null, or an object it does not hold: the unscaled min_score).
bool IsVisible(const InstanceVisibility& visible, const Instance& instance,
               const recognition::RecognitionModel* model);
// The thresholds in force for a map with these options recognising with `model` (null:
// none loaded): each one the map leaves unset is the model's database's.
InstanceVisibility ResolveVisibility(const VisibilityOptions& options,
                                     const recognition::RecognitionModel* model);

}  // namespace skimap::server

#endif  // SERVER_CORE_RECOGNITION_INSTANCE_RECONCILER_H_
