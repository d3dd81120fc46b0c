// Training views of a model rendered on the CPU: what `skimap objects add MODEL` trains
// from instead of a recorded BOP sequence. Orbits around the model's bounding-box centre at
// each elevation, `azimuths` views evenly spaced, at each distance (by default the sim's
// own training orbits: elevations 10, 35 and 60 degrees, 36 views each, at
// max(0.6 m, 2.8 x the model's diameter)), lit from above, back faces drawn (models wind
// their triangles either way), nothing behind the object (black, no depth).
//
//   std::vector<TrainingView> views = RenderTrainingViews(mesh, K, {});
//
// Thread safety: reentrant.
#ifndef SKIMAP_SIM_TRAINING_VIEWS_H_
#define SKIMAP_SIM_TRAINING_VIEWS_H_

#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <vector>

#include "dataset/types.h"
#include "sim/mesh.h"

namespace skimap::sim {

struct TrainingViewOptions {
  std::vector<float> elevations_deg = {10, 35, 60};
  int azimuths = 36;
  std::vector<float> distances;  // metres; empty: max(0.6, 2.8 x diameter)
};

struct TrainingView {
  cv::Mat bgr;              // CV_8UC3
  cv::Mat depth_mm;         // CV_16UC1, 0 where nothing was hit
  cv::Mat mask;             // CV_8UC1, 255 on the model
  Eigen::Isometry3d T_m2c;  // camera <- model (BOP cam_R_m2c, cam_t_m2c in metres)
};

// Views in which the model covers at least one pixel. REQUIRES: mesh non-empty.
std::vector<TrainingView> RenderTrainingViews(const Mesh& mesh, const dataset::Intrinsics& K,
                                              const TrainingViewOptions& options = {});

}  // namespace skimap::sim

#endif  // SKIMAP_SIM_TRAINING_VIEWS_H_
