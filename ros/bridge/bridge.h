// Bridge: the skimap-ros node. A robot's RGB-D camera in, skimapd's map out.
//
// In (topics relative to the node's namespace, remappable):
//   depth/image        sensor_msgs/Image, 16UC1 (mm) or 32FC1 (m), registered to colour,
//                      or with ~compressed_depth depth/image/compressedDepth, image_transport's
//                      compressedDepth (ros/bag/compressed_depth.h)
//   rgb/image          sensor_msgs/Image rgb8 / bgr8 / rgba8 / bgra8 / mono8, or with
//                      ~compressed_color rgb/image/compressed, a sensor_msgs/CompressedImage
//   rgb/camera_info    sensor_msgs/CameraInfo (with ~use_color false: depth/camera_info,
//                      and no colour topic: a depth-only camera, voxels grey)
//   pose_updates       nav_msgs/Path: corrected camera poses (fixed frame) after a loop
//                      closure, each stamped as the frame it corrects; forwarded to
//                      UpdatePoses (stamps of frames the map does not hold are counted)
// The three camera topics are paired by message_filters (ApproximateTime); each frame's
// camera pose is tf's fixed frame <- the depth image's frame at its stamp, waited for up to
// ~tf_wait. Frames go to skimapd through FrameSender (bounded, drop-and-count).
//
// Out, at ~publish_rate when the map changed (latched):
//   map                nav_msgs/OccupancyGrid, cell for cell skimapd's grid
//   height_map         sensor_msgs/Image 32FC1 (+ height_map/info, nav_msgs/MapMetaData)
//   instances          visualization_msgs/MarkerArray (recognition maps), and tf frames
//                      object_<id> (fixed frame <- object model)
//   trajectory         nav_msgs/Path of the acknowledged frames
// Services: ~instances_in_box, ~instances_in_sphere (skimap_ros/InstancesIn*), ~save_map
// (skimap_ros/SaveMap, only with ~save_dir set).
//
// Parameters (private): BridgeParams (bridge_params.h), read by ReadParams; docs/ros.md
// lists them.
//
// Thread safety: callbacks run on a multi-threaded spinner; the members they share are
// thread safe (FrameSender, MapClient) or atomic.
#ifndef ROS_BRIDGE_BRIDGE_H_
#define ROS_BRIDGE_BRIDGE_H_

#include <ros/ros.h>

#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "client/map_client.h"
#include "ros/bridge/bridge_params.h"
#include "ros/bridge/frame_sender.h"

namespace skimap::rosbridge {

class Bridge {
 public:
  // Connects to skimapd (waits up to 30 s), creates or opens the map, subscribes and
  // advertises. Unavailable / the server's error otherwise.
  static absl::StatusOr<std::unique_ptr<Bridge>> Start(ros::NodeHandle nh,
                                                       ros::NodeHandle private_nh,
                                                       const BridgeParams& params);
  ~Bridge();

  // Waits for the frames in flight, writes ~stats_file, logs the summary.
  void Finish();

  class Impl;

 private:
  explicit Bridge(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace skimap::rosbridge

#endif  // ROS_BRIDGE_BRIDGE_H_
