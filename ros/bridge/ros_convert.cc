#include "ros/bridge/ros_convert.h"

#include <cstring>

#include "absl/strings/str_cat.h"

namespace skimap::rosbridge {

geometry_msgs::Pose ToRosPose(const v1::Pose& pose) {
  geometry_msgs::Pose out;
  out.position.x = pose.translation().x();
  out.position.y = pose.translation().y();
  out.position.z = pose.translation().z();
  out.orientation.w = pose.rotation().w();
  out.orientation.x = pose.rotation().x();
  out.orientation.y = pose.rotation().y();
  out.orientation.z = pose.rotation().z();
  return out;
}

v1::Pose FromRosPose(const geometry_msgs::Pose& pose) {
  v1::Pose out;
  out.mutable_translation()->set_x(pose.position.x);
  out.mutable_translation()->set_y(pose.position.y);
  out.mutable_translation()->set_z(pose.position.z);
  out.mutable_rotation()->set_w(pose.orientation.w);
  out.mutable_rotation()->set_x(pose.orientation.x);
  out.mutable_rotation()->set_y(pose.orientation.y);
  out.mutable_rotation()->set_z(pose.orientation.z);
  return out;
}

namespace {

void SetInfo(double resolution, uint32_t width, uint32_t height, double origin_x, double origin_y,
             const ros::Time& stamp, nav_msgs::MapMetaData* info) {
  info->map_load_time = stamp;
  info->resolution = static_cast<float>(resolution);
  info->width = width;
  info->height = height;
  info->origin.position.x = origin_x;
  info->origin.position.y = origin_y;
  info->origin.orientation.w = 1;
}

}  // namespace

nav_msgs::OccupancyGrid ToRosGrid(const v1::OccupancyGrid& grid, const std::string& frame_id,
                                  const ros::Time& stamp) {
  nav_msgs::OccupancyGrid out;
  out.header.frame_id = frame_id;
  out.header.stamp = stamp;
  SetInfo(grid.resolution(), grid.width(), grid.height(), grid.origin_x(), grid.origin_y(), stamp,
          &out.info);
  out.data.assign(grid.data().begin(), grid.data().end());  // an empty map: no cells
  return out;
}

RosHeightMap ToRosHeightMap(const v1::HeightMap& map, const std::string& frame_id,
                            const ros::Time& stamp) {
  RosHeightMap out;
  out.image.header.frame_id = frame_id;
  out.image.header.stamp = stamp;
  out.image.width = map.width();
  out.image.height = map.height();
  out.image.encoding = "32FC1";
  out.image.is_bigendian = 0;
  out.image.step = map.width() * 4;
  const auto* bytes = reinterpret_cast<const uint8_t*>(map.heights().data());
  out.image.data.assign(bytes, bytes + size_t(map.heights_size()) * 4);
  SetInfo(map.resolution(), map.width(), map.height(), map.origin_x(), map.origin_y(), stamp,
          &out.info);
  return out;
}

visualization_msgs::MarkerArray ToMarkers(const std::vector<v1::Instance>& instances,
                                          const std::string& frame_id, const ros::Time& stamp) {
  visualization_msgs::MarkerArray out;
  visualization_msgs::Marker clear;
  clear.header.frame_id = frame_id;
  clear.header.stamp = stamp;
  clear.ns = "instances";
  clear.action = visualization_msgs::Marker::DELETEALL;
  out.markers.push_back(clear);
  for (const v1::Instance& instance : instances) {
    visualization_msgs::Marker arrow;
    arrow.header = clear.header;
    arrow.ns = "instances";
    arrow.id = static_cast<int>(instance.id() * 2);
    arrow.type = visualization_msgs::Marker::ARROW;
    arrow.action = visualization_msgs::Marker::ADD;
    arrow.pose = ToRosPose(instance.pose());
    arrow.scale.x = 0.15;
    arrow.scale.y = 0.02;
    arrow.scale.z = 0.02;
    arrow.color.r = 1.0f;
    arrow.color.g = 0.5f;
    arrow.color.a = 1.0f;
    out.markers.push_back(arrow);
    visualization_msgs::Marker text = arrow;
    text.id = arrow.id + 1;
    text.type = visualization_msgs::Marker::TEXT_VIEW_FACING;
    text.pose.position.z += 0.1;
    text.pose.orientation = geometry_msgs::Quaternion();
    text.pose.orientation.w = 1;
    text.scale.x = text.scale.y = 0;
    text.scale.z = 0.06;
    text.color.r = text.color.g = text.color.b = 1.0f;
    text.text =
        absl::StrCat(instance.object_name().empty() ? instance.object() : instance.object_name(),
                     " #", instance.id());
    out.markers.push_back(text);
  }
  return out;
}

std::vector<geometry_msgs::TransformStamped> ToTransforms(
    const std::vector<v1::Instance>& instances, const std::string& frame_id,
    const ros::Time& stamp) {
  std::vector<geometry_msgs::TransformStamped> out;
  for (const v1::Instance& instance : instances) {
    geometry_msgs::TransformStamped t;
    t.header.frame_id = frame_id;
    t.header.stamp = stamp;
    t.child_frame_id = absl::StrCat("object_", instance.id());
    const geometry_msgs::Pose pose = ToRosPose(instance.pose());
    t.transform.translation.x = pose.position.x;
    t.transform.translation.y = pose.position.y;
    t.transform.translation.z = pose.position.z;
    t.transform.rotation = pose.orientation;
    out.push_back(t);
  }
  return out;
}

nav_msgs::Path ToPath(const std::vector<SentFrame>& frames, const std::string& frame_id) {
  nav_msgs::Path path;
  path.header.frame_id = frame_id;
  for (const SentFrame& f : frames) {
    geometry_msgs::PoseStamped p;
    p.header.frame_id = frame_id;
    p.header.stamp.fromNSec(f.stamp_ns);
    p.pose = ToRosPose(f.pose);
    path.poses.push_back(p);
  }
  if (!path.poses.empty()) path.header.stamp = path.poses.back().header.stamp;
  return path;
}

}  // namespace skimap::rosbridge
