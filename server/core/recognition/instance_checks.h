// Checks of a posed object (an instance's pose) against what the map holds and what a
// camera saw (docs/recognition.md, "Global instances"): the colour fit against the RGB
// volume, the view count against a frame's depth, and overlap with another object.
//
// Thread safety: pure functions; the volume is read (the caller holds the map's lock).
#ifndef SERVER_CORE_RECOGNITION_INSTANCE_CHECKS_H_
#define SERVER_CORE_RECOGNITION_INSTANCE_CHECKS_H_

#include <cstdint>

#include "Eigen/Geometry"
#include "codec/image_codec.h"
#include "perception/recognition/recognition_model.h"
#include "perception/rgbd_frame.h"
#include "server/core/maps/map_state.h"

namespace skimap::server {

// How well a posed object agrees with the map's RGB volume: the fraction of its surface
// points whose voxel in the map is occupied, and the fraction of those whose colour is
// close (mean absolute difference per channel under 40).
struct SurfaceFit {
  float observed = 0;
  float colour = 0;
};
SurfaceFit FitSurface(const Volume& rgb, const recognition::ObjectShape& shape,
                      const Eigen::Isometry3f& pose);

// A recognised frame's depth, to check instances against what the camera saw.
struct ViewFrame {
  const perception::DepthImage* depth = nullptr;  // not owned; REQUIRES non-null
  double depth_scale = 0;                         // metres per depth unit
  perception::PinholeCamera camera;               // REQUIRES: depth is its size
  Eigen::Isometry3f camera_from_world = Eigen::Isometry3f::Identity();
  double min_depth = 0.1;  // metres: the sensor's range starts here (the map's min_depth)
};

// The view check: the object's surface points at `pose` (about 100 of them, evenly taken:
// a map counts them in each of its keyframes), projected into the frame. The
// trained surface is voxels (1 cm), so a point may lie up to 1 cm off the true surface,
// sideways too: each point looks at 3 x 3 pixels spanning 1 cm around its own. It agrees
// when one of them measured within 15 mm of its depth; it conflicts (the camera saw
// through it) when at least 5 of them measured and all lie more than 15 mm behind it;
// otherwise (occluded, unmeasured, at a silhouette, nearer than the sensor's range, never
// nearer than 1 cm, or on a surface the view ray grazes: more than 70 degrees off its
// normal) it counts for neither. Adds to *agree and *conflict.
void CountView(const recognition::ObjectShape& shape, const Eigen::Isometry3f& pose,
               const ViewFrame& view, uint32_t* agree, uint32_t* conflict);

// True if object `a` at `pose_a` and object `b` at `pose_b` would occupy the same space:
// more than a fifth of a's surface points lie inside b's bounding box (shrunk by 5 mm).
bool Overlap(const recognition::ObjectShape& a, const Eigen::Isometry3f& pose_a,
             const recognition::ObjectShape& b, const Eigen::Isometry3f& pose_b);

}  // namespace skimap::server

#endif  // SERVER_CORE_RECOGNITION_INSTANCE_CHECKS_H_
