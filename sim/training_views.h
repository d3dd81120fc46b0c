// Training views of a model rendered on the CPU: what `skimap objects add MODEL` trains
// from instead of a recorded BOP sequence. Orbits around the model's bounding-box centre at
// each elevation, `azimuths` views evenly spaced, at each distance (by default the sim's
// own training orbits: elevations 10, 35 and 60 degrees, 36 views each, at
// max(0.6 m, 2.8 x the model's diameter)), back faces drawn (models wind their triangles
// either way).
//
// What a camera would add to a perfect render, each optional (clutter alone by default:
// the best F1 on the validation render, docs/recognition.md "Objects from their models"):
//   clutter   a random background behind the model (shapes, stripes and noise in random
//             colours), so keypoints on the silhouette describe an edge against a scene,
//             not against black; the background has no depth and is outside the mask.
//   lighting  each view lit by a random room light (sim/scene.h RandomLighting) instead of
//             one fixed light from above.
//   sensor    colour noise (sigma 2 grey levels) and the Kinect depth model
//             (sim/depth_noise.h) on the model's depth.
// The random streams are seeded per view from `seed`, so the views are reproducible.
//
//   std::vector<TrainingView> views = RenderTrainingViews(mesh, K, {});
//
// Thread safety: reentrant.
#ifndef SKIMAP_SIM_TRAINING_VIEWS_H_
#define SKIMAP_SIM_TRAINING_VIEWS_H_

#include <Eigen/Geometry>
#include <cstdint>
#include <opencv2/core.hpp>
#include <random>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/string_view.h"
#include "dataset/types.h"
#include "sim/mesh.h"

namespace skimap::sim {

struct TrainingViewOptions {
  std::vector<float> elevations_deg = {10, 35, 60};
  int azimuths = 36;
  std::vector<float> distances;  // metres; empty: max(0.6, 2.8 x diameter)
  bool clutter = true;
  bool lighting = false;
  bool sensor = false;
  uint64_t seed = 1;
};

struct TrainingView {
  cv::Mat bgr;              // CV_8UC3
  cv::Mat depth_mm;         // CV_16UC1, 0 where the model was not seen
  cv::Mat mask;             // CV_8UC1, 255 on the model
  Eigen::Isometry3d T_m2c;  // camera <- model (BOP cam_R_m2c, cam_t_m2c in metres)
};

// Views in which the model covers at least one pixel. REQUIRES: mesh non-empty.
std::vector<TrainingView> RenderTrainingViews(const Mesh& mesh, const dataset::Intrinsics& K,
                                              const TrainingViewOptions& options = {});

// Parses `text`, a comma list of clutter, lighting and sensor, or "none", into the three
// switches of `options` (those not named are off). InvalidArgument naming `field`.
absl::Status ParseViewEffects(absl::string_view text, const std::string& field,
                              TrainingViewOptions* options);

// Writes `views` as the BOP scene folder `scene_dir` (rgb/, depth/ in millimetres,
// mask_visib/, scene_gt.json, scene_camera.json with the model frame as the world frame):
// what the object service trains from. kInternal naming the file on failure.
absl::Status WriteTrainingScene(const std::vector<TrainingView>& views,
                                const dataset::Intrinsics& K, int obj_id,
                                const std::string& scene_dir);

// A random cluttered background of `size` (CV_8UC3): what `clutter` puts behind a view.
cv::Mat ClutterBackground(cv::Size size, std::mt19937_64& rng);

}  // namespace skimap::sim

#endif  // SKIMAP_SIM_TRAINING_VIEWS_H_
