// Orbits of training views around a model. See training_views.h for the contract.
#include "sim/training_views.h"

#include <algorithm>

#include "sim/rasterizer.h"
#include "sim/trajectory.h"

namespace skimap::sim {

std::vector<TrainingView> RenderTrainingViews(const Mesh& mesh, const dataset::Intrinsics& K,
                                              const TrainingViewOptions& options) {
  const Eigen::Vector3f centre = mesh.Bounds().center();
  std::vector<float> distances = options.distances;
  if (distances.empty()) distances = {std::max(0.6f, 2.8f * mesh.Diameter())};
  // Light from above and a little behind the first views, as a room's ceiling lights.
  Lighting light;
  light.dir_world = Eigen::Vector3f(0.3f, 0.2f, -1.f).normalized();
  const Instance model{&mesh, Eigen::Isometry3f::Identity(), 1, /*two_sided=*/true};
  std::vector<TrainingView> views;
  RenderOutput out;
  for (float distance : distances) {
    for (float elevation : options.elevations_deg) {
      for (const Eigen::Isometry3f& T_wc :
           MakeTrainingOrbit(centre, distance, elevation, 0.f, std::max(1, options.azimuths))) {
        Render({model}, K, T_wc, light, &out, 0.01f);
        TrainingView v;
        v.mask = out.ids == 1;
        if (cv::countNonZero(v.mask) == 0) continue;
        v.bgr = out.bgr.clone();
        out.depth.convertTo(v.depth_mm, CV_16UC1, 1000.0);
        v.T_m2c = T_wc.inverse().cast<double>();
        views.push_back(std::move(v));
      }
    }
  }
  return views;
}

}  // namespace skimap::sim
