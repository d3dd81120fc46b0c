// skimap-ros against real components: a rosmaster, skimapd and the bridge as processes,
// this test as a ROS node publishing the real YCB-Video frames (depth, colour,
// camera_info) with tf. The bridge's map holds exactly the voxels of the same frames sent
// as API frames; the /map it publishes is, cell for cell, the grid skimapd serves; the
// trajectory has every frame; a loop closure on pose_updates changes the map exactly as
// UpdatePoses does; the services answer; a frame the bridge cannot pose is counted, not
// sent.
#include "tests/ros/bridge_fixture.h"

namespace skimap::testing {
namespace {

TEST_F(BridgeTest, LiveTopicsMakeTheMapAndMapIsSkimapdsGridCellForCell) {
  ros::NodeHandle nh;
  std::mutex mu;
  nav_msgs::OccupancyGrid last_map;
  nav_msgs::Path last_path;
  int maps = 0;
  ros::Subscriber map_sub = nh.subscribe<nav_msgs::OccupancyGrid>(
      ns_ + "/map", 5, [&](const nav_msgs::OccupancyGrid::ConstPtr& m) {
        std::lock_guard<std::mutex> lock(mu);
        last_map = *m;
        ++maps;
      });
  ros::Subscriber path_sub =
      nh.subscribe<nav_msgs::Path>(ns_ + "/trajectory", 5, [&](const nav_msgs::Path::ConstPtr& p) {
        std::lock_guard<std::mutex> lock(mu);
        last_path = *p;
      });
  sensor_msgs::Image last_height;
  nav_msgs::MapMetaData last_height_info;
  ros::Subscriber height_sub = nh.subscribe<sensor_msgs::Image>(
      ns_ + "/height_map", 5, [&](const sensor_msgs::Image::ConstPtr& m) {
        std::lock_guard<std::mutex> lock(mu);
        last_height = *m;
      });
  ros::Subscriber height_info_sub = nh.subscribe<nav_msgs::MapMetaData>(
      ns_ + "/height_map/info", 5, [&](const nav_msgs::MapMetaData::ConstPtr& m) {
        std::lock_guard<std::mutex> lock(mu);
        last_height_info = *m;
      });
  StartBridge("live");
  PublishFrames(nh);
  ASSERT_TRUE(WaitFor([&] { return Frames("live") == 10; }, 60)) << BridgeLog();

  // The same voxels as the frames sent through the API.
  EXPECT_EQ(Compare(Voxels(*client_, "maps/live"), Reference("live_ref")), "same");

  // /map: wait for a publication after the last frame, then compare with the gRPC grid.
  ros::WallDuration(1.0).sleep();
  v1::GetOccupancyGridRequest request;
  request.set_map("maps/live");
  auto grid = client_->GetOccupancyGrid(request);
  ASSERT_TRUE(grid.ok()) << grid.status();
  {
    std::lock_guard<std::mutex> lock(mu);
    ASSERT_GT(maps, 0) << BridgeLog();
    EXPECT_EQ(last_map.header.frame_id, "world");
    EXPECT_EQ(last_map.info.width, grid->width());
    EXPECT_EQ(last_map.info.height, grid->height());
    EXPECT_FLOAT_EQ(last_map.info.resolution, grid->resolution());
    EXPECT_DOUBLE_EQ(last_map.info.origin.position.x, grid->origin_x());
    EXPECT_DOUBLE_EQ(last_map.info.origin.position.y, grid->origin_y());
    ASSERT_EQ(last_map.data.size(), grid->data().size());
    size_t differ = 0, occupied = 0, free_cells = 0;
    for (size_t i = 0; i < last_map.data.size(); ++i) {
      differ += last_map.data[i] != static_cast<int8_t>(grid->data()[i]);
      occupied += last_map.data[i] == 100;
      free_cells += last_map.data[i] == 0;
    }
    EXPECT_EQ(differ, 0u);
    std::printf("/map: %zu cells, %zu occupied, %zu free\n", last_map.data.size(), occupied,
                free_cells);
    // Measured 2026-11-28: 82 occupied and 498 free cells at 2 cm; floors at two thirds.
    EXPECT_GT(occupied, 54u);
    EXPECT_GT(free_cells, 332u);
    // The height map: skimapd's heights, as a 32FC1 image with its metadata.
    v1::GetHeightMapRequest height_request;
    height_request.set_map("maps/live");
    auto heights = client_->GetHeightMap(height_request);
    ASSERT_TRUE(heights.ok()) << heights.status();
    EXPECT_EQ(last_height.encoding, "32FC1");
    EXPECT_EQ(last_height.width, heights->width());
    EXPECT_EQ(last_height.height, heights->height());
    ASSERT_EQ(last_height.data.size(), size_t(heights->heights_size()) * 4);
    EXPECT_EQ(
        std::memcmp(last_height.data.data(), heights->heights().data(), last_height.data.size()),
        0);
    EXPECT_EQ(last_height_info.width, heights->width());
    EXPECT_DOUBLE_EQ(last_height_info.origin.position.x, heights->origin_x());
    ASSERT_EQ(last_path.poses.size(), 10u);
    EXPECT_EQ(last_path.poses[3].header.stamp, frames_[3].stamp);
    EXPECT_NEAR(last_path.poses[3].pose.position.x, frames_[3].T_wc.translation().x(), 1e-9);
  }

  // A loop closure: frames 5..9 moved by 3 cm along x, on pose_updates and, for the
  // reference map, through UpdatePoses itself.
  nav_msgs::Path closure;
  closure.header.frame_id = "world";
  v1::UpdatePosesRequest update;
  update.set_map("maps/live_ref");
  for (int i = 5; i < 10; ++i) {
    Eigen::Isometry3d T = frames_[i].T_wc;
    T.translation().x() += 0.03;
    geometry_msgs::PoseStamped p;
    p.header.stamp = frames_[i].stamp;
    const Eigen::Quaterniond q(T.rotation());
    p.pose.orientation.w = q.w(), p.pose.orientation.x = q.x();
    p.pose.orientation.y = q.y(), p.pose.orientation.z = q.z();
    p.pose.position.x = T.translation().x(), p.pose.position.y = T.translation().y();
    p.pose.position.z = T.translation().z();
    closure.poses.push_back(p);
    v1::PoseUpdate* u = update.add_updates();
    u->set_sequence(i);
    *u->mutable_pose() = ReferenceFrame(frames_[i], "", 0).pose();
    u->mutable_pose()->mutable_translation()->set_x(T.translation().x());
  }
  // An unknown stamp is skipped (and logged), not an error.
  geometry_msgs::PoseStamped stranger = closure.poses[0];
  stranger.header.stamp = ros::Time(5.0);
  closure.poses.push_back(stranger);
  const VoxelSet before = Voxels(*client_, "maps/live");
  ros::Publisher updates = nh.advertise<nav_msgs::Path>(ns_ + "/pose_updates", 1);
  ASSERT_TRUE(WaitFor([&] { return updates.getNumSubscribers() > 0; }, 10));
  updates.publish(closure);
  ASSERT_TRUE(client_->UpdatePoses(update).ok());
  const VoxelSet expected = Voxels(*client_, "maps/live_ref");
  ASSERT_TRUE(WaitFor([&] { return Voxels(*client_, "maps/live") != before; }, 20)) << BridgeLog();
  EXPECT_EQ(Compare(Voxels(*client_, "maps/live"), expected), "same");
  ASSERT_TRUE(WaitFor(
      [&] {
        std::lock_guard<std::mutex> lock(mu);
        return last_path.poses.size() == 10 &&
               std::abs(last_path.poses[7].pose.position.x -
                        (frames_[7].T_wc.translation().x() + 0.03)) < 1e-9;
      },
      10));

  // Services: instances in a box (a map without recognition says so), save.
  ros::ServiceClient box =
      nh.serviceClient<skimap_ros::InstancesInBox>(ns_ + "/skimap_ros/instances_in_box");
  skimap_ros::InstancesInBox in_box;
  in_box.request.min.x = in_box.request.min.y = in_box.request.min.z = -10;
  in_box.request.max.x = in_box.request.max.y = in_box.request.max.z = 10;
  ASSERT_TRUE(box.call(in_box));
  EXPECT_FALSE(in_box.response.success);
  EXPECT_NE(in_box.response.message.find("no recognition"), std::string::npos)
      << in_box.response.message;
  ros::ServiceClient save = nh.serviceClient<skimap_ros::SaveMap>(ns_ + "/skimap_ros/save_map");
  skimap_ros::SaveMap saved;
  saved.request.path = "../escape";
  ASSERT_TRUE(save.call(saved));
  EXPECT_FALSE(saved.response.success);
  EXPECT_NE(saved.response.message.find(".."), std::string::npos);
  saved.request.path = "run1/live.skimap";
  ASSERT_TRUE(save.call(saved));
  EXPECT_TRUE(saved.response.success) << saved.response.message;
  EXPECT_GT(saved.response.bytes, 1000u);
  EXPECT_EQ(fs::file_size(dir_ / "saved/run1/live.skimap"), saved.response.bytes);
  EXPECT_TRUE(fs::exists(dir_ / "saved/run1/live.skimap.yaml"));

  EXPECT_EQ(StopBridge(), 0) << BridgeLog();
  const std::string stats = StatsJson();
  EXPECT_NE(stats.find("\"acked\": 10"), std::string::npos) << stats;
  EXPECT_NE(stats.find("\"dropped\": 0"), std::string::npos) << stats;
}

TEST_F(BridgeTest, CompressedColourMakesTheSameMap) {
  ros::NodeHandle nh;
  StartBridge("png", {"_compressed_color:=true"});
  PublishFrames(nh, {}, /*compressed=*/true);
  ASSERT_TRUE(WaitFor([&] { return Frames("png") == 10; }, 60)) << BridgeLog();
  EXPECT_EQ(Compare(Voxels(*client_, "maps/png"), Reference("png_ref")), "same");
}

TEST_F(BridgeTest, CompressedDepthMakesTheSameMap) {
  ros::NodeHandle nh;
  StartBridge("cd", {"_compressed_depth:=true"});
  compressed_depth_ = "rvl";
  PublishFrames(nh);
  ASSERT_TRUE(WaitFor([&] { return Frames("cd") == 10; }, 60)) << BridgeLog();
  EXPECT_EQ(Compare(Voxels(*client_, "maps/cd"), Reference("cd_ref")), "same");
}

TEST_F(BridgeTest, ACompressedDepthMessageOfAnotherSizeThanCameraInfoIsRefusedAndCounted) {
  ros::NodeHandle nh;
  StartBridge("cd_bad", {"_compressed_depth:=true"});
  compressed_depth_ = "rvl";
  // Frame 5 claims a quarter-size image (valid RVL of it): the camera_info says 640x480.
  edit_compressed_depth_ = [&](int i, sensor_msgs::CompressedImage* m) {
    if (i != 5) return;
    MmFrame small = frames_[i];
    small.width /= 2;
    small.height /= 2;
    small.depth_mm.assign(size_t(small.width) * small.height, 1000);
    *m = CompressedDepthMessage(small, "rvl");
  };
  PublishFrames(nh);
  ASSERT_TRUE(WaitFor([&] { return Frames("cd_bad") == 9; }, 60)) << BridgeLog();
  ros::WallDuration(0.5).sleep();
  EXPECT_EQ(StopBridge(), 0);
  EXPECT_EQ(Frames("cd_bad"), 9u);
  // Refused by the decoder, before it decoded anything, not later by the frame checks.
  EXPECT_NE(BridgeLog().find("compressedDepth image is 320x240, camera_info is for 640x480"),
            std::string::npos)
      << BridgeLog();
  const std::string stats = StatsJson();
  EXPECT_NE(stats.find("\"bad\": 1"), std::string::npos) << stats;
}

TEST_F(BridgeTest, ADepthOnlyCameraMakesTheMapInGrey) {
  ros::NodeHandle nh;
  StartBridge("depth_only", {"_use_color:=false"});
  publish_color_ = false;
  PublishFrames(nh);
  ASSERT_TRUE(WaitFor([&] { return Frames("depth_only") == 10; }, 60)) << BridgeLog();
  EXPECT_EQ(Compare(Voxels(*client_, "maps/depth_only"),
                    ReferenceVoxels(*client_, frames_, "depth_only_ref", /*with_color=*/false)),
            "same");
}

TEST_F(BridgeTest, AFrameWithoutAPoseIsCountedNotSent) {
  ros::NodeHandle nh;
  StartBridge("gaps", {"_tf_wait:=0.2"});
  // The last frame is stamped long after every transform and gets none of its own: tf
  // cannot extrapolate that far, so the bridge has no pose for it.
  frames_[9].stamp = ros::Time(2000.0);
  PublishFrames(nh, {9});
  ASSERT_TRUE(WaitFor([&] { return Frames("gaps") == 9; }, 60)) << BridgeLog();
  ros::WallDuration(0.5).sleep();
  EXPECT_EQ(StopBridge(), 0);
  const std::string stats = StatsJson();
  EXPECT_NE(stats.find("\"no_pose\": 1"), std::string::npos) << stats;
  EXPECT_EQ(Frames("gaps"), 9u);
}

}  // namespace
}  // namespace skimap::testing

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ::testing::AddGlobalTestEnvironment(new skimap::testing::RosEnvironment);
  return RUN_ALL_TESTS();
}
