// Held-out evaluation of an ObjectDatabase on annotated views (e.g. training frames kept
// out of training): per object, how often features and whole views are classified to the
// right object. Used by tests/perception/objects and bench/objects_bench.cc.
//
// Per feature (features detected inside the object's eroded mask, as in training):
//   top1:     the forest's most confident class belongs to the right object;
//   verified: the most confident *verified* candidate exists (ObjectDatabase::Recognize);
//   correct:  ... and belongs to the right object.
// Per view: every verified prediction votes for its object with its confidence; the view
// is correct when the right object gets the most votes.
//
// Thread safety: reentrant.
#ifndef SKIMAP_PERCEPTION_OBJECTS_EVALUATION_H_
#define SKIMAP_PERCEPTION_OBJECTS_EVALUATION_H_

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "perception/objects/object_database.h"

namespace skimap::objects {

struct ObjectAccuracy {
  int obj_id = 0;
  int64_t features = 0;
  int64_t top1 = 0;
  int64_t verified = 0;
  int64_t correct = 0;
  int views = 0;
  int views_correct = 0;
  double predict_seconds = 0;  // forest + verification time over all features

  double Top1Rate() const { return features ? double(top1) / features : 0; }
  double VerifiedPrecision() const { return verified ? double(correct) / verified : 0; }
  double ViewRate() const { return views ? double(views_correct) / views : 0; }
};

struct EvaluationOptions {
  // Views to evaluate: use_frame(obj_id, frame_id); null = every frame.
  std::function<bool(int, int)> use_frame;
};

// Evaluates every database object on its own folder <dataset_root>/train/<obj_id>/.
// NotFound for a missing folder; errors of the reader pass through.
absl::StatusOr<std::vector<ObjectAccuracy>> EvaluateViews(const ObjectDatabase& db,
                                                          const std::string& dataset_root,
                                                          const EvaluationOptions& options);

// Sums per-object results (obj_id 0).
ObjectAccuracy Total(const std::vector<ObjectAccuracy>& per_object);

}  // namespace skimap::objects

#endif  // SKIMAP_PERCEPTION_OBJECTS_EVALUATION_H_
