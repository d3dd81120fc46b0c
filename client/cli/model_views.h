// `skimap objects add MODEL`: a 3D model file's training views as the object service's
// TrainingFrames, rendered on this machine (sim/model_io.h reads the model,
// sim/training_views.h renders it): colour as PNG, depth as 16-bit PNG in millimetres,
// the model's mask as PNG, the pose camera <- model.
//
//   absl::StatusOr<std::vector<v1::TrainingFrame>> frames = ModelTrainingFrames(
//       "cereal.obj", {.units = "auto", .camera = ""});
//
// Thread safety: reentrant.
#ifndef CLIENT_CLI_MODEL_VIEWS_H_
#define CLIENT_CLI_MODEL_VIEWS_H_

#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "sim/training_views.h"
#include "skimap/v1/objects.pb.h"

namespace skimap::client {

struct ModelViewOptions {
  std::string units = "auto";        // auto, m or mm (sim::ParseModelUnits)
  std::string camera;                // a BOP camera.json; "": a Kinect (525 px, 640x480)
  std::vector<float> distances;      // metres; empty: the sim's training orbits' distance
  int azimuths = 36;                 // views per orbit
  sim::TrainingViewOptions effects;  // only its clutter, lighting and sensor are used
};

// Errors: the model's (NotFound, InvalidArgument naming the file), a bad --model_units or
// camera file, FailedPrecondition when no view shows the model.
absl::StatusOr<std::vector<v1::TrainingFrame>> ModelTrainingFrames(const std::string& path,
                                                                   const ModelViewOptions& options);

}  // namespace skimap::client

#endif  // CLIENT_CLI_MODEL_VIEWS_H_
