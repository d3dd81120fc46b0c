// skimapd's answers as ROS messages, and back: pure conversions the bridge publishes.
//   - OccupancyGrid -> nav_msgs/OccupancyGrid: the same cells in the same order (row-major,
//     x fastest, -1 unknown, 0 free, 100 occupied, 1-99 costs), origin at the lower-left
//     corner of cell (0, 0), z = 0, identity orientation;
//   - HeightMap -> a 32FC1 sensor_msgs/Image (row j = cell row j, NaN unknown) and its
//     nav_msgs/MapMetaData (resolution, size, origin);
//   - instances -> visualization_msgs/MarkerArray (a DELETEALL, then per instance an arrow
//     along the object's x axis and a text with its object name and id, namespace
//     "instances", marker id = instance id) and tf frames "object_<id>";
//   - acknowledged frames -> nav_msgs/Path (the camera's poses, stamped as the frames).
//
// Thread safety: pure functions.
#ifndef ROS_BRIDGE_ROS_CONVERT_H_
#define ROS_BRIDGE_ROS_CONVERT_H_

#include <geometry_msgs/Pose.h>
#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/MapMetaData.h>
#include <nav_msgs/OccupancyGrid.h>
#include <nav_msgs/Path.h>
#include <ros/time.h>
#include <sensor_msgs/Image.h>
#include <visualization_msgs/MarkerArray.h>

#include <string>
#include <vector>

#include "ros/bridge/frame_sender.h"
#include "skimap/v1/instances.pb.h"
#include "skimap/v1/queries.pb.h"

namespace skimap::rosbridge {

geometry_msgs::Pose ToRosPose(const v1::Pose& pose);
v1::Pose FromRosPose(const geometry_msgs::Pose& pose);

// `grid.data` must be raw (the client library decodes zstd).
nav_msgs::OccupancyGrid ToRosGrid(const v1::OccupancyGrid& grid, const std::string& frame_id,
                                  const ros::Time& stamp);

struct RosHeightMap {
  sensor_msgs::Image image;
  nav_msgs::MapMetaData info;
};
RosHeightMap ToRosHeightMap(const v1::HeightMap& map, const std::string& frame_id,
                            const ros::Time& stamp);

visualization_msgs::MarkerArray ToMarkers(const std::vector<v1::Instance>& instances,
                                          const std::string& frame_id, const ros::Time& stamp);
std::vector<geometry_msgs::TransformStamped> ToTransforms(
    const std::vector<v1::Instance>& instances, const std::string& frame_id,
    const ros::Time& stamp);

nav_msgs::Path ToPath(const std::vector<SentFrame>& frames, const std::string& frame_id);

}  // namespace skimap::rosbridge

#endif  // ROS_BRIDGE_ROS_CONVERT_H_
