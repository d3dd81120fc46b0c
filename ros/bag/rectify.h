// Rectifier: frames from a camera whose CameraInfo carries lens distortion, undistorted
// before they are sent, so the server's pinhole back-projection (K only) puts every pixel
// on its true ray. What image_proc's rectify does for a monocular camera, for both images:
//
//   - the rectified images are those of the pinhole camera (fx, fy, cx, cy) of K, the
//     intrinsics the frame carries (a skew in K is undone too), and R is taken as identity
//     (a depth camera is not a stereo pair);
//   - depth is resampled to the nearest source pixel (interpolating depth across an edge
//     would invent points between surfaces); its values are the z of the same points, so
//     they are copied as they are;
//   - colour is resampled bilinearly; a compressed colour image is decoded first and sent
//     raw (RGB8) after;
//   - pixels whose source lies outside the image get no depth (0) and black.
//
// Distortion models (CameraInfo.distortion_model, REP 104): "plumb_bob" (k1 k2 t1 t2 k3)
// and "rational_polynomial" (k1 k2 t1 t2 k3 k4 k5 k6), OpenCV's pinhole model;
// "equidistant" (k1 k2 k3 k4, OpenCV's fisheye model). A D of zeros (or empty) means
// rectified images already: nothing is done, whatever the model says.
//
// The undistortion maps are built once per camera (size, K, model, D) and kept until the
// camera_info changes: about 10 ms to build, then about 1 ms per 640x480 frame of depth
// and colour.
//
// Thread safety: Rectify may be called from several threads at once (the maps are shared
// read-only; building new ones takes a lock).
#ifndef ROS_BAG_RECTIFY_H_
#define ROS_BAG_RECTIFY_H_

#include <sensor_msgs/CameraInfo.h>

#include <memory>
#include <string>

#include "absl/base/thread_annotations.h"
#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "base/mutex.h"
#include "ros/bag/bag_frames.h"

namespace skimap::bag {

// True if `info` has a non-zero distortion coefficient.
bool HasDistortion(const sensor_msgs::CameraInfo& info);

class Rectifier {
 public:
  Rectifier();
  ~Rectifier();

  // Undistorts `frame` (made from messages with `info`: its depth_mm and colour, as
  // MakeRosFrame leaves them) in place; OK and nothing done when `info` has no distortion.
  // InvalidArgument naming `info_topic` and the field for a distortion model other than the
  // three above, a D of the wrong length for its model, a non-finite coefficient or K, or
  // a frame of another size than `info` says; naming `color_topic` for a compressed colour
  // image that does not decode.
  absl::Status Rectify(const sensor_msgs::CameraInfo& info, const std::string& info_topic,
                       const std::string& color_topic, RosFrame* frame);

 private:
  struct Maps;
  // The maps for `info`, built if the camera differs from the last one.
  absl::StatusOr<std::shared_ptr<const Maps>> MapsFor(const sensor_msgs::CameraInfo& info,
                                                      const std::string& info_topic);

  Mutex mu_;
  std::shared_ptr<const Maps> maps_ ABSL_GUARDED_BY(mu_);
};

}  // namespace skimap::bag

#endif  // ROS_BAG_RECTIFY_H_
