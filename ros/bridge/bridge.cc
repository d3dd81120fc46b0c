#include "ros/bridge/bridge.h"

#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_broadcaster.h>
#include <tf2_ros/transform_listener.h>

#include <algorithm>
#include <filesystem>
#include <fstream>

#include "absl/strings/str_cat.h"
#include "client/frame_depth.h"
#include "client/map_files.h"
#include "ros/bag/rectify.h"
#include "ros/bag/ros_frames.h"
#include "ros/bridge/bridge_report.h"
#include "ros/bridge/camera_input.h"
#include "ros/bridge/ros_convert.h"
#include "skimap_ros/InstancesInBox.h"
#include "skimap_ros/InstancesInSphere.h"
#include "skimap_ros/SaveMap.h"

namespace skimap::rosbridge {
namespace {

using Clock = std::chrono::steady_clock;
using sensor_msgs::CameraInfo;
using sensor_msgs::Image;

}  // namespace

class Bridge::Impl {
 public:
  Impl(ros::NodeHandle nh, ros::NodeHandle pnh, const BridgeParams& params)
      : nh_(nh), pnh_(pnh), params_(params), map_name_(absl::StrCat("maps/", params.map)) {}

  absl::Status Start() {
    client::MapClient::Options options;
    // Unary calls (grids, the map's stats) give up after 10 s: a stalled skimapd must not
    // hold the node's callbacks, nor its shutdown, for the library's default minute.
    options.timeout = absl::Seconds(10);
    client::Connection::Files files{params_.token_file, params_.tls_ca, params_.tls_cert,
                                    params_.tls_key};
    absl::StatusOr<client::Connection> connection = client::Connection::FromFiles(files);
    if (!connection.ok()) return connection.status();
    options.connection = *connection;
    client_ = client::MapClient::Connect(params_.server, options);
    if (absl::Status s = client_->WaitForServer(absl::Seconds(30)); !s.ok()) {
      return absl::UnavailableError(absl::StrCat("~server ", params_.server, ": ", s.message()));
    }
    absl::StatusOr<v1::Map> map = client_->GetMap(map_name_);
    if (absl::IsNotFound(map.status())) {
      v1::CreateMapRequest create;
      create.set_map_id(params_.map);
      create.mutable_options()->set_resolution(params_.resolution);
      if (params_.recognition) create.mutable_options()->mutable_recognition()->set_enabled(true);
      map = client_->CreateMap(create);
    }
    if (!map.ok()) return map.status();
    encoding_ = *ParseDepthEncoding(params_.depth_encoding);
    FrameSender::Options sender;
    sender.map_name = map_name_;
    sender.window = params_.window;
    sender.queue_frames = params_.queue_frames;
    sender.first_sequence = map->stats().frames();
    sender_ = std::make_unique<FrameSender>(client_.get(), sender);

    tf_ = std::make_unique<tf2_ros::Buffer>();
    listener_ = std::make_unique<tf2_ros::TransformListener>(*tf_, nh_);
    camera_ = std::make_unique<CameraInput>(
        nh_, params_,
        [this](const Image& depth, const bag::ColorMessage& color, const CameraInfo& info) {
          OnFrame(depth, color, info);
        },
        [this](const absl::Status& s) { Refused(s); });
    camera_->Start();
    pose_updates_ = nh_.subscribe("pose_updates", 10, &Impl::OnPoseUpdates, this);

    map_pub_ = nh_.advertise<nav_msgs::OccupancyGrid>("map", 1, /*latch=*/true);
    height_pub_ = nh_.advertise<sensor_msgs::Image>("height_map", 1, true);
    height_info_pub_ = nh_.advertise<nav_msgs::MapMetaData>("height_map/info", 1, true);
    markers_pub_ = nh_.advertise<visualization_msgs::MarkerArray>("instances", 1, true);
    path_pub_ = nh_.advertise<nav_msgs::Path>("trajectory", 1, true);
    box_srv_ = pnh_.advertiseService("instances_in_box", &Impl::OnInstancesInBox, this);
    sphere_srv_ = pnh_.advertiseService("instances_in_sphere", &Impl::OnInstancesInSphere, this);
    if (!params_.save_dir.empty()) {
      save_srv_ = pnh_.advertiseService("save_map", &Impl::OnSaveMap, this);
    }
    if (params_.publish_rate > 0) {
      timer_ = nh_.createWallTimer(ros::WallDuration(1.0 / params_.publish_rate),
                                   [this](const ros::WallTimerEvent&) { Publish(); });
    }
    started_ = Clock::now();
    ROS_INFO("skimap-ros: streaming to %s map %s (%llu frames so far), poses in %s",
             params_.server.c_str(), params_.map.c_str(), (unsigned long long)map->stats().frames(),
             params_.fixed_frame.c_str());
    return absl::OkStatus();
  }

  void Finish() {
    timer_.stop();
    // The last map, unless skimapd stopped answering (then its calls would only time out).
    if (sender_->WaitIdle(std::chrono::seconds(10))) Publish();
    WriteReport(sender_->Stats(), no_pose_.load(), bad_.load(),
                std::chrono::duration<double>(Clock::now() - started_).count(), params_.stats_file);
  }

 private:
  void Refused(const absl::Status& s) {
    ++bad_;
    ROS_WARN_THROTTLE(5, "skimap-ros: frame refused: %s", std::string(s.message()).c_str());
  }

  void OnFrame(const Image& depth, const bag::ColorMessage& color, const CameraInfo& info) {
    const Clock::time_point received = Clock::now();
    const std::string& camera =
        params_.camera_frame.empty() ? depth.header.frame_id : params_.camera_frame;
    geometry_msgs::TransformStamped T;
    try {
      T = tf_->lookupTransform(params_.fixed_frame, camera, depth.header.stamp,
                               ros::Duration(params_.tf_wait));
    } catch (const tf2::TransformException& e) {
      ++no_pose_;
      ROS_WARN_THROTTLE(5, "skimap-ros: no pose for a frame at %.3f: %s",
                        depth.header.stamp.toSec(), e.what());
      return;
    }
    Eigen::Isometry3d T_wc = Eigen::Isometry3d::Identity();
    const auto& r = T.transform.rotation;
    T_wc.linear() = Eigen::Quaterniond(r.w, r.x, r.y, r.z).normalized().toRotationMatrix();
    T_wc.translation() = Eigen::Vector3d(T.transform.translation.x, T.transform.translation.y,
                                         T.transform.translation.z);
    absl::StatusOr<bag::RosFrame> frame =
        bag::MakeRosFrame(depth, camera_->depth_topic(), color, info, camera_->info_topic(), T_wc);
    absl::Status s = frame.status();
    if (s.ok()) s = rectifier_.Rectify(info, camera_->info_topic(), color.topic, &*frame);
    if (s.ok()) {
      s = client::SetFrameDepth(frame->depth_mm.data(), frame->width, frame->height, &frame->frame,
                                encoding_);
    }
    if (!s.ok()) {
      Refused(s);
      return;
    }
    sender_->Offer(std::move(frame->frame), depth.header.stamp.toNSec(), received);
  }

  void OnPoseUpdates(const nav_msgs::Path::ConstPtr& path) {
    v1::UpdatePosesRequest request;
    request.set_map(map_name_);
    std::vector<std::pair<uint64_t, v1::Pose>> poses;
    uint64_t unknown = 0;
    for (const geometry_msgs::PoseStamped& p : path->poses) {
      std::optional<uint64_t> sequence = sender_->SequenceOf(p.header.stamp.toNSec());
      if (!sequence.has_value()) {
        ++unknown;
        continue;
      }
      v1::PoseUpdate* update = request.add_updates();
      update->set_sequence(*sequence);
      *update->mutable_pose() = FromRosPose(p.pose);
      poses.emplace_back(*sequence, update->pose());
    }
    if (unknown > 0) {
      ROS_WARN("skimap-ros: pose_updates: %llu of %zu stamps are not frames of the map",
               (unsigned long long)unknown, path->poses.size());
    }
    if (request.updates_size() == 0) return;
    absl::StatusOr<v1::UpdatePosesResponse> done = client_->UpdatePoses(request);
    if (!done.ok()) {
      ROS_ERROR("skimap-ros: UpdatePoses: %s", std::string(done.status().message()).c_str());
      return;
    }
    sender_->SetPoses(poses);
    ++pose_updates_done_;
    ROS_INFO("skimap-ros: %llu frames re-posed (%llu voxels touched)",
             (unsigned long long)done->frames_updated(),
             (unsigned long long)done->voxels_touched());
  }

  // Publishes what changed since the last time.
  void Publish() {
    std::lock_guard<std::mutex> lock(publish_mu_);
    absl::StatusOr<v1::Map> map = client_->GetMap(map_name_);
    if (!map.ok()) {
      ROS_WARN_THROTTLE(10, "skimap-ros: GetMap: %s", std::string(map.status().message()).c_str());
      return;
    }
    uint64_t version = 0;
    std::vector<SentFrame> trajectory = sender_->Trajectory(&version);
    const ros::Time now = ros::Time::now();
    const auto key =
        std::make_tuple(map->stats().frames(), map->stats().voxels(), pose_updates_done_.load());
    if (key != last_key_) {
      v1::GetOccupancyGridRequest grid_request;
      grid_request.set_map(map_name_);
      grid_request.set_data_encoding(v1::GRID_ENCODING_ZSTD);
      if (params_.inflation_radius > 0) grid_request.set_inflation_radius(params_.inflation_radius);
      grid_request.set_keep_seen_through(params_.keep_seen_through);
      absl::StatusOr<v1::OccupancyGrid> grid = client_->GetOccupancyGrid(grid_request);
      if (grid.ok()) {
        map_pub_.publish(ToRosGrid(*grid, params_.fixed_frame, now));
      } else {
        ROS_WARN("skimap-ros: GetOccupancyGrid: %s", std::string(grid.status().message()).c_str());
      }
      if (params_.publish_height_map) {
        v1::GetHeightMapRequest height_request;
        height_request.set_map(map_name_);
        absl::StatusOr<v1::HeightMap> height = client_->GetHeightMap(height_request);
        if (height.ok()) {
          RosHeightMap out = ToRosHeightMap(*height, params_.fixed_frame, now);
          height_pub_.publish(out.image);
          height_info_pub_.publish(out.info);
        }
      }
      if (map->options().recognition().enabled()) {
        v1::ListInstancesRequest list;
        list.set_map(map_name_);
        absl::StatusOr<std::vector<v1::Instance>> instances = client_->ListAllInstances(list);
        if (instances.ok()) {
          markers_pub_.publish(ToMarkers(*instances, params_.fixed_frame, now));
          instance_tfs_ = ToTransforms(*instances, params_.fixed_frame, now);
        }
      }
      last_key_ = key;
    }
    if (!instance_tfs_.empty()) {
      for (geometry_msgs::TransformStamped& t : instance_tfs_) t.header.stamp = now;
      broadcaster_.sendTransform(instance_tfs_);
    }
    if (version != path_version_) {
      path_pub_.publish(ToPath(trajectory, params_.fixed_frame));
      path_version_ = version;
    }
  }

  template <typename Response>
  bool Instances(v1::ListInstancesRequest list, double min_score, Response& res) {
    list.set_map(map_name_);
    list.set_min_score(min_score);
    absl::StatusOr<std::vector<v1::Instance>> instances = client_->ListAllInstances(list);
    res.success = instances.ok();
    if (!instances.ok()) {
      res.message = std::string(instances.status().message());
      return true;
    }
    for (const v1::Instance& i : *instances) {
      skimap_ros::Instance out;
      out.id = i.id();
      out.obj_id = i.obj_id();
      out.object_name = i.object_name();
      out.pose = ToRosPose(i.pose());
      out.score = i.score();
      out.fit = i.fit();
      out.frames = i.frames();
      res.instances.push_back(out);
    }
    return true;
  }

  bool OnInstancesInBox(skimap_ros::InstancesInBox::Request& req,
                        skimap_ros::InstancesInBox::Response& res) {
    v1::ListInstancesRequest list;
    v1::Box3* box = list.mutable_box();
    box->mutable_min()->set_x(req.min.x);
    box->mutable_min()->set_y(req.min.y);
    box->mutable_min()->set_z(req.min.z);
    box->mutable_max()->set_x(req.max.x);
    box->mutable_max()->set_y(req.max.y);
    box->mutable_max()->set_z(req.max.z);
    return Instances(list, req.min_score, res);
  }

  bool OnInstancesInSphere(skimap_ros::InstancesInSphere::Request& req,
                           skimap_ros::InstancesInSphere::Response& res) {
    v1::ListInstancesRequest list;
    v1::Sphere* sphere = list.mutable_sphere();
    sphere->mutable_center()->set_x(req.center.x);
    sphere->mutable_center()->set_y(req.center.y);
    sphere->mutable_center()->set_z(req.center.z);
    sphere->set_radius(req.radius);
    return Instances(list, req.min_score, res);
  }

  bool OnSaveMap(skimap_ros::SaveMap::Request& req, skimap_ros::SaveMap::Response& res) {
    absl::StatusOr<std::filesystem::path> path = SavePath(params_.save_dir, req.path);
    absl::Status s = path.status();
    uint64_t bytes = 0;
    if (s.ok()) {
      std::error_code ec;
      std::filesystem::create_directories(path->parent_path(), ec);
      const std::string tmp = path->string() + ".part";
      std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
      if (!out) s = absl::PermissionDeniedError(absl::StrCat("path: cannot write ", tmp));
      if (s.ok()) {
        v1::ExportMapRequest request;
        request.set_name(map_name_);
        request.set_with_journal(true);
        s = client_->ExportMap(request, [&](std::string_view piece) {
          out.write(piece.data(), piece.size());
          bytes += piece.size();
          return out ? absl::OkStatus() : absl::DataLossError("path: write failed");
        });
        out.close();
        if (s.ok()) {
          std::filesystem::rename(tmp, *path, ec);
          if (ec) s = absl::InternalError(absl::StrCat("path: ", ec.message()));
        } else {
          std::filesystem::remove(tmp, ec);
        }
      }
      if (s.ok()) {
        v1::GetOccupancyGridRequest grid_request;
        grid_request.set_map(map_name_);
        absl::StatusOr<v1::OccupancyGrid> grid = client_->GetOccupancyGrid(grid_request);
        s = grid.ok() ? client::WriteRosMap(*grid, path->string() + ".yaml") : grid.status();
      }
    }
    res.success = s.ok();
    res.message = s.ok() ? path->string() : std::string(s.message());
    res.bytes = bytes;
    return true;
  }

  ros::NodeHandle nh_, pnh_;
  const BridgeParams params_;
  const std::string map_name_;
  v1::DepthEncoding encoding_ = v1::DEPTH_ENCODING_ZSTD;
  std::unique_ptr<client::MapClient> client_;
  std::unique_ptr<FrameSender> sender_;
  std::unique_ptr<tf2_ros::Buffer> tf_;
  std::unique_ptr<tf2_ros::TransformListener> listener_;
  tf2_ros::TransformBroadcaster broadcaster_;
  bag::Rectifier rectifier_;             // undoes the camera_info's distortion, if any
  std::unique_ptr<CameraInput> camera_;  // after what its callbacks use: destroyed first
  ros::Subscriber pose_updates_;
  ros::Publisher map_pub_, height_pub_, height_info_pub_, markers_pub_, path_pub_;
  ros::ServiceServer box_srv_, sphere_srv_, save_srv_;
  ros::WallTimer timer_;
  std::atomic<uint64_t> no_pose_{0}, bad_{0}, pose_updates_done_{0};
  Clock::time_point started_;
  std::mutex publish_mu_;
  std::tuple<uint64_t, uint64_t, uint64_t> last_key_{~0ull, ~0ull, ~0ull};  // publish_mu_
  std::vector<geometry_msgs::TransformStamped> instance_tfs_;               // publish_mu_
  uint64_t path_version_ = ~0ull;                                           // publish_mu_
};

absl::StatusOr<std::unique_ptr<Bridge>> Bridge::Start(ros::NodeHandle nh,
                                                      ros::NodeHandle private_nh,
                                                      const BridgeParams& params) {
  auto impl = std::make_unique<Impl>(nh, private_nh, params);
  if (absl::Status s = impl->Start(); !s.ok()) return s;
  return std::unique_ptr<Bridge>(new Bridge(std::move(impl)));
}

Bridge::Bridge(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Bridge::~Bridge() = default;
void Bridge::Finish() { impl_->Finish(); }

}  // namespace skimap::rosbridge
