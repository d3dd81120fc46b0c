// Training views from BOP datasets for the object service: the train/{obj_id:06d}/ scenes
// of a dataset root, and one frame's files as a v1::TrainingFrame (images sent as stored:
// 16-bit PNG depth, PNG or JPEG colour, PNG mask_visib).
//
// Thread safety: functions of their arguments.
#ifndef CLIENT_CLI_TRAINING_FRAMES_H_
#define CLIENT_CLI_TRAINING_FRAMES_H_

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/statusor.h"
#include "dataset/types.h"
#include "skimap/v1/objects.pb.h"

namespace skimap::client {

// The objects of a BOP dataset root with a train/ folder: (obj_id, scene folder, name from
// objects.json or ""), by obj_id. NotFound without train/.
struct TrainingObject {
  int obj_id = 0;
  std::string scene_dir;
  std::string name;
};
absl::StatusOr<std::vector<TrainingObject>> ListTrainingObjects(const std::string& dataset_root);

// The view of obj_id in `frame`, or nullopt when the frame does not annotate it or has no
// visible mask for it. FailedPrecondition without depth; NotFound for a missing file.
absl::StatusOr<std::optional<v1::TrainingFrame>> ToTrainingFrame(const dataset::Frame& frame,
                                                                 int obj_id);

}  // namespace skimap::client

#endif  // CLIENT_CLI_TRAINING_FRAMES_H_
