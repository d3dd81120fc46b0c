#include "server/core/recognition/view_keyframes.h"

#include <cmath>
#include <numbers>

namespace skimap::server {

bool ViewKeyframes::Offer(uint64_t sequence, const perception::DepthImage& depth,
                          double depth_scale, const perception::PinholeCamera& camera,
                          const Eigen::Isometry3d& world_from_camera) {
  if (options_.capacity == 0) return false;
  const double min_angle = options_.min_angle_deg * std::numbers::pi / 180;
  for (const Kept& k : kept_) {
    const double distance =
        (k.world_from_camera.translation() - world_from_camera.translation()).norm();
    const double angle =
        Eigen::AngleAxisd(k.world_from_camera.linear().transpose() * world_from_camera.linear())
            .angle();
    if (distance < options_.min_distance && angle < min_angle) return false;
  }
  if (kept_.size() >= options_.capacity) kept_.pop_front();
  Kept k{.sequence = sequence,
         .depth = {},
         .depth_scale = depth_scale,
         .camera = {},
         .world_from_camera = world_from_camera};
  perception::HalfResolution(depth, camera, &k.depth, &k.camera);
  kept_.push_back(std::move(k));
  RebuildViews();
  return true;
}

void ViewKeyframes::Move(uint64_t sequence, const Eigen::Isometry3d& world_from_camera) {
  for (Kept& k : kept_) {
    if (k.sequence == sequence) {
      k.world_from_camera = world_from_camera;
      RebuildViews();
      return;
    }
  }
}

void ViewKeyframes::RebuildViews() {
  views_.clear();
  views_.reserve(kept_.size());
  for (const Kept& k : kept_) {
    views_.push_back({.depth = &k.depth,
                      .depth_scale = k.depth_scale,
                      .camera = k.camera,
                      .camera_from_world = k.world_from_camera.inverse().cast<float>(),
                      .min_depth = options_.min_depth});
  }
}

}  // namespace skimap::server
