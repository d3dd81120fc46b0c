// Offline training pipeline entry points (paper §3, Fig. 3): objects in, ObjectDatabase
// out. Transport independent: the gRPC ObjectService and the CLI call these.
//
//   auto builder = ObjectDatabaseBuilder::Create(params);
//   (*builder)->AddObject(*TrainObject("data/sk/train/000003", 3, "mug", params, {}));
//   absl::StatusOr<ObjectDatabase> db = (*builder)->Build(progress);   // stacking + forest
//
//   // or, for a whole BOP dataset (train/<obj_id>/ folders):
//   absl::StatusOr<ObjectDatabase> db = TrainObjectDatabase("data/sk", params, {});
//
// Progress: fn(BuildProgress) with a stage ("frames", "mean_shift", "forest"), called on
// the calling thread or (forest) on worker threads, serialized; it must not block long.
//
// Thread safety: the free functions are reentrant; an ObjectDatabaseBuilder is not thread
// safe (its const Build may run concurrently with other const calls).
#ifndef SKIMAP_PERCEPTION_OBJECTS_TRAINING_H_
#define SKIMAP_PERCEPTION_OBJECTS_TRAINING_H_

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "perception/objects/object_database.h"
#include "perception/objects/object_trainer.h"

namespace skimap::objects {

struct BuildProgress {
  std::string stage;  // "frames" | "mean_shift" | "forest"
  int obj_id = 0;     // the object being trained (0 for "forest")
  int64_t done = 0;
  int64_t total = 0;
};
using ProgressFn = std::function<void(const BuildProgress&)>;

class ObjectDatabaseBuilder {
 public:
  // Resolves and validates params (InvalidArgument naming the field).
  static absl::StatusOr<std::unique_ptr<ObjectDatabaseBuilder>> Create(
      const ObjectDatabaseParams& params);

  const ObjectDatabaseParams& params() const { return params_; }
  const std::vector<TrainedObject>& objects() const { return objects_; }

  // Adds a trained object (AlreadyExists if its obj_id is present; InvalidArgument if its
  // descriptors do not have this database's layout).
  absl::Status AddObject(TrainedObject object);
  // Removes an object; NotFound if absent.
  absl::Status RemoveObject(int obj_id);

  // Class stacking (k voxels with most evidence per object) and forest training on the
  // raw descriptors of the stacked voxels. FailedPrecondition without objects.
  absl::StatusOr<ObjectDatabase> Build(const ProgressFn& progress = nullptr) const;

 private:
  explicit ObjectDatabaseBuilder(ObjectDatabaseParams params) : params_(std::move(params)) {}

  ObjectDatabaseParams params_;
  std::vector<TrainedObject> objects_;
};

struct DatasetTrainingOptions {
  // Frames to train on: use_frame(obj_id, frame_id); null = every frame. Tests hold out
  // views with it (e.g. frame_id % 4 == 3).
  std::function<bool(int, int)> use_frame;
  std::vector<int> obj_ids;  // TrainObjectDatabase: objects to train; empty = all
  int threads = 2;           // mean shift and forest threads, >= 1
  ProgressFn progress;
};

// Trains one object from a BOP scene folder whose frames annotate obj_id (a training
// orbit, train/<obj_id>/). Frames where the object has no mask or no visible pixel are
// skipped; NotFound if the folder is missing, InvalidArgument for bad params,
// FailedPrecondition if no frame contributed a descriptor.
absl::StatusOr<TrainedObject> TrainObject(const std::string& scene_dir, int obj_id,
                                          std::string name, const ObjectDatabaseParams& params,
                                          const DatasetTrainingOptions& options = {});

// Trains every object of a BOP dataset root (train/<obj_id>/ folders; names from
// objects.json if present) and builds the database.
absl::StatusOr<ObjectDatabase> TrainObjectDatabase(const std::string& dataset_root,
                                                   const ObjectDatabaseParams& params,
                                                   const DatasetTrainingOptions& options = {});

// obj_id -> name from <dataset_root>/objects.json; empty if the file is absent.
absl::StatusOr<std::vector<std::pair<int, std::string>>> ListTrainingObjects(
    const std::string& dataset_root);

}  // namespace skimap::objects

#endif  // SKIMAP_PERCEPTION_OBJECTS_TRAINING_H_
