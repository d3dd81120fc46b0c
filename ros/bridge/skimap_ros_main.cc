// skimap-ros: the ROS 1 node that streams a robot's RGB-D camera to skimapd and publishes
// the map back (bridge.h; docs/ros.md). Exits 1 with the reason when it cannot start (a bad
// parameter, skimapd unreachable).
//
//   skimap-ros _server:=127.0.0.1:50051 _map:=lab _fixed_frame:=map
//       depth/image:=/camera/aligned_depth_to_color/image_raw
//       rgb/image:=/camera/color/image_raw rgb/camera_info:=/camera/color/camera_info
//   (one command line), or roslaunch skimap_ros skimap_ros.launch (launch/).
//
// Stopping: the first SIGINT / SIGTERM stops the node in order (bridge.h, Finish: the
// frames in flight get up to 10 s for their acks, the last map is published, the report
// written), then the stream is released; should that take longer than ~shutdown_timeout
// (a skimapd that stopped reading holds gRPC's blocking write), the node exits with
// status 2. A second signal exits at once (status 130).
#include <ros/ros.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <mutex>
#include <string>
#include <thread>

#include "ros/bridge/bridge.h"

namespace {
std::atomic<bool> stop{false};
void OnSignal(int) {
  if (stop.exchange(true)) std::_Exit(130);  // the second signal: no more waiting
}

// Exits the process with status 2 unless Done() comes within `timeout` seconds.
class ExitUnlessDoneIn {
 public:
  explicit ExitUnlessDoneIn(double timeout)
      : thread_([this, timeout] {
          std::unique_lock<std::mutex> lock(mu_);
          if (cv_.wait_for(lock, std::chrono::duration<double>(timeout), [&] { return done_; }))
            return;
          std::fprintf(stderr,
                       "skimap-ros: skimapd did not release the stream within %.1f s "
                       "(~shutdown_timeout); exiting without it\n",
                       timeout);
          std::_Exit(2);
        }) {}
  void Done() {
    {
      std::lock_guard<std::mutex> lock(mu_);
      done_ = true;
    }
    cv_.notify_all();
    thread_.join();
  }

 private:
  std::mutex mu_;
  std::condition_variable cv_;
  bool done_ = false;
  std::thread thread_;  // last: it starts once the members it uses exist
};
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
  ExitUnlessDoneIn watchdog(params->shutdown_timeout);
  ros::shutdown();
  spinner.stop();  // no callback runs while the bridge is destroyed
  bridge->reset();
  watchdog.Done();
  return 0;
}
