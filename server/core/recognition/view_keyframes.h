// The depth a map keeps to check instances against what its cameras saw from many places
// (docs/recognition.md, "Global instances", the view conflict). A recognised frame is kept
// when it looks from a new vantage point: no kept frame lies within `min_distance` of its
// camera centre and `min_angle_deg` of its orientation. Its depth is kept at half
// resolution (every second pixel of every second row, the intrinsics halved to match), the
// oldest frame goes when `capacity` are kept. Not persisted: a reloaded map starts without.
//
// Thread safety: none; the map's worker owns it.
#ifndef SERVER_CORE_RECOGNITION_VIEW_KEYFRAMES_H_
#define SERVER_CORE_RECOGNITION_VIEW_KEYFRAMES_H_

#include <cstddef>
#include <cstdint>
#include <deque>
#include <vector>

#include "Eigen/Geometry"
#include "codec/image_codec.h"
#include "perception/rgbd_frame.h"
#include "server/core/recognition/instance_checks.h"

namespace skimap::server {

class ViewKeyframes {
 public:
  struct Options {
    size_t capacity = 64;
    double min_distance = 0.15;  // metres
    double min_angle_deg = 15;
    double min_depth = 0.1;  // metres: the sensor's range starts here (the map's min_depth)
  };

  explicit ViewKeyframes(Options options) : options_(options) {}

  // Keeps frame `sequence` (its pose world <- camera) if it looks from a new vantage point.
  // Returns whether it was kept. REQUIRES: depth is camera.width x camera.height.
  bool Offer(uint64_t sequence, const perception::DepthImage& depth, double depth_scale,
             const perception::PinholeCamera& camera, const Eigen::Isometry3d& world_from_camera);

  // Frame `sequence` moved (UpdatePoses); a frame not kept is ignored.
  void Move(uint64_t sequence, const Eigen::Isometry3d& world_from_camera);

  // The kept frames as views for CountView; valid until the next Offer or Move.
  const std::vector<ViewFrame>& views() const { return views_; }

 private:
  struct Kept {
    uint64_t sequence;
    perception::DepthImage depth;  // half resolution
    double depth_scale;
    perception::PinholeCamera camera;  // halved
    Eigen::Isometry3d world_from_camera;
  };

  void RebuildViews();

  Options options_;
  std::deque<Kept> kept_;  // oldest first
  std::vector<ViewFrame> views_;
};

}  // namespace skimap::server

#endif  // SERVER_CORE_RECOGNITION_VIEW_KEYFRAMES_H_
