#include "perception/recognition/active_sphere.h"

#include <algorithm>
#include <vector>

namespace skimap::recognition {

Sphere ActiveSphere(const perception::CameraPose& pose, const LabelObservations& observations,
                    double distance, double radius) {
  double d = distance, r = radius;
  if (d <= 0) {
    d = 1.0;
    const std::vector<LabelObservation>& labels = observations.labels;
    if (!labels.empty()) {
      std::vector<float> z;
      for (const LabelObservation& o : labels) z.push_back(o.point.z());
      std::nth_element(z.begin(), z.begin() + z.size() / 2, z.end());
      d = z[z.size() / 2];
      const Eigen::Vector3f centre(0, 0, static_cast<float>(d));
      std::vector<float> dist;
      for (const LabelObservation& o : labels) dist.push_back((o.point - centre).norm());
      const size_t k = std::min(dist.size() - 1, dist.size() * 9 / 10);
      std::nth_element(dist.begin(), dist.begin() + k, dist.end());
      r = std::clamp<double>(dist[k], radius, std::max(radius, kMaxSceneRadius));
    }
  }
  const Eigen::Vector3d centre = pose.rotation * Eigen::Vector3d(0, 0, d) + pose.translation;
  return {centre.cast<float>(), static_cast<float>(r)};
}

}  // namespace skimap::recognition
