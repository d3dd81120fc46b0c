// CameraInput: the skimap-ros node's camera topics, paired. Subscribes to depth (raw, or
// image_transport's compressedDepth, decoded first: ros/bag/compressed_depth.h), colour
// (raw or compressed, or none) and camera_info as BridgeParams say (topic names in
// bridge.h), pairs them with message_filters' ApproximateTime policy (~sync_queue per
// topic) and hands each paired frame to `on_frame`. A compressedDepth message that does not
// decode goes to `on_bad` instead (it never reaches the pairing).
//
// Thread safety: the callbacks run on the node's spinner threads, possibly at once; they
// must be thread safe. Destroying the CameraInput unsubscribes (no callback after).
#ifndef ROS_BRIDGE_CAMERA_INPUT_H_
#define ROS_BRIDGE_CAMERA_INPUT_H_

#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>

#include <functional>
#include <memory>
#include <string>

#include "absl/status/status.h"
#include "ros/bag/ros_frames.h"
#include "ros/bridge/bridge_params.h"

namespace skimap::rosbridge {

class CameraInput {
 public:
  using FrameFn =
      std::function<void(const sensor_msgs::Image& depth, const bag::ColorMessage& color,
                         const sensor_msgs::CameraInfo& info)>;
  using BadFn = std::function<void(const absl::Status&)>;

  // Resolves the topic names (relative to `nh`, remapped); subscribes nothing yet.
  CameraInput(ros::NodeHandle nh, const BridgeParams& params, FrameFn on_frame, BadFn on_bad);
  ~CameraInput();

  // Subscribes: the callbacks may run from then on (on the spinner's threads), so call it
  // once what they use is in place. Once.
  void Start();

  // The resolved topic names, for errors; set before Start.
  const std::string& depth_topic() const;
  const std::string& info_topic() const;

 private:
  class Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace skimap::rosbridge

#endif  // ROS_BRIDGE_CAMERA_INPUT_H_
