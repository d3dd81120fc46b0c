// skimap-ros: the ROS 1 node that streams a robot's RGB-D camera to skimapd and publishes
// the map back (bridge.h; docs/ros.md). Exits 1 with the reason when it cannot start (a bad
// parameter, skimapd unreachable).
//
//   skimap-ros _server:=127.0.0.1:50051 _map:=lab _fixed_frame:=map
//       depth/image:=/camera/aligned_depth_to_color/image_raw
//       rgb/image:=/camera/color/image_raw rgb/camera_info:=/camera/color/camera_info
//   (one command line), or roslaunch skimap_ros skimap_ros.launch (launch/).
#include <ros/ros.h>

#include <atomic>
#include <csignal>
#include <cstdio>
#include <string>
#include <thread>

#include "ros/bridge/bridge.h"

namespace {
std::atomic<bool> stop{false};
void OnSignal(int) { stop = true; }
}  // namespace

int main(int argc, char** argv) {
  // SIGINT / SIGTERM: the frames in flight are acknowledged and the last map published
  // before the node leaves the graph.
  ros::init(argc, argv, "skimap_ros", ros::init_options::NoSigintHandler);
  std::setvbuf(stdout, nullptr, _IOLBF, 0);  // log lines reach a redirected log as they come
  std::signal(SIGINT, OnSignal);
  std::signal(SIGTERM, OnSignal);
  ros::NodeHandle nh;
  ros::NodeHandle pnh("~");
  absl::StatusOr<skimap::rosbridge::BridgeParams> params = skimap::rosbridge::ReadParams(pnh);
  if (!params.ok()) {
    ROS_FATAL("skimap-ros: %s", std::string(params.status().message()).c_str());
    return 1;
  }
  ros::AsyncSpinner spinner(2);
  spinner.start();
  absl::StatusOr<std::unique_ptr<skimap::rosbridge::Bridge>> bridge =
      skimap::rosbridge::Bridge::Start(nh, pnh, *params);
  if (!bridge.ok()) {
    ROS_FATAL("skimap-ros: %s", std::string(bridge.status().message()).c_str());
    return 1;
  }
  while (!stop && ros::ok()) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  (*bridge)->Finish();
  ros::shutdown();
  spinner.stop();  // no callback runs while the bridge is destroyed
  bridge->reset();
  return 0;
}
