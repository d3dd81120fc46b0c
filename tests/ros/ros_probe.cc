// ros_probe: what a ROS user of skimap-ros sees, for tests written in C++20 (which cannot
// include ROS 1's headers): waits up to SECONDS for a MarkerArray on MARKERS and the tf
// frames object_<id>, calls SERVICE (skimap_ros/InstancesInSphere, radius 1000 m) and
// prints one line each:
//   markers <arrows> <texts> <text>|<text>|...
//   tf <object frames seen>
//   sphere <success> <instances> <ids, comma separated>
// Usage: ros_probe MARKERS SERVICE SECONDS   (ROS_MASTER_URI from the environment)
#include <ros/ros.h>
#include <tf2_msgs/TFMessage.h>
#include <visualization_msgs/MarkerArray.h>

#include <cstdio>
#include <mutex>
#include <set>
#include <string>

#include "skimap_ros/InstancesInSphere.h"

int main(int argc, char** argv) {
  if (argc < 4) return 2;
  ros::init(argc, argv, "ros_probe", ros::init_options::AnonymousName);
  ros::NodeHandle nh;
  std::mutex mu;
  visualization_msgs::MarkerArray markers;
  bool got_markers = false;
  std::set<std::string> frames;
  ros::Subscriber m = nh.subscribe<visualization_msgs::MarkerArray>(
      argv[1], 1, [&](const visualization_msgs::MarkerArray::ConstPtr& msg) {
        std::lock_guard<std::mutex> lock(mu);
        markers = *msg;
        got_markers = true;
      });
  ros::Subscriber tf =
      nh.subscribe<tf2_msgs::TFMessage>("/tf", 10, [&](const tf2_msgs::TFMessage::ConstPtr& msg) {
        std::lock_guard<std::mutex> lock(mu);
        for (const auto& t : msg->transforms) {
          if (t.child_frame_id.rfind("object_", 0) == 0) frames.insert(t.child_frame_id);
        }
      });
  ros::AsyncSpinner spinner(1);
  spinner.start();
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(std::stod(argv[3]));
  while (ros::WallTime::now() < end) {
    {
      std::lock_guard<std::mutex> lock(mu);
      if (got_markers && !frames.empty()) break;
    }
    ros::WallDuration(0.05).sleep();
  }
  {
    std::lock_guard<std::mutex> lock(mu);
    int arrows = 0, texts = 0;
    std::string labels;
    for (const auto& marker : markers.markers) {
      if (marker.action != visualization_msgs::Marker::ADD) continue;  // the DELETEALL
      arrows += marker.type == visualization_msgs::Marker::ARROW;
      if (marker.type == visualization_msgs::Marker::TEXT_VIEW_FACING) {
        ++texts;
        labels += (labels.empty() ? "" : "|") + marker.text;
      }
    }
    std::printf("markers %d %d %s\ntf %zu\n", arrows, texts, labels.c_str(), frames.size());
  }
  ros::ServiceClient client = nh.serviceClient<skimap_ros::InstancesInSphere>(argv[2]);
  client.waitForExistence(ros::Duration(10));
  skimap_ros::InstancesInSphere call;
  call.request.radius = 1000;
  if (client.call(call)) {
    std::string ids;
    for (const auto& i : call.response.instances) {
      ids += (ids.empty() ? "" : ",") + std::to_string(i.id);
    }
    std::printf("sphere %d %zu %s\n", call.response.success ? 1 : 0, call.response.instances.size(),
                ids.c_str());
  } else {
    std::printf("sphere call failed\n");
  }
  std::fflush(stdout);
  ros::shutdown();
  return 0;
}
