// skimap-ros against real components: a rosmaster, skimapd and the bridge as processes,
// this test as a ROS node publishing the real YCB-Video frames (depth, colour,
// camera_info) with tf. The bridge's map holds exactly the voxels of the same frames sent
// as API frames; the /map it publishes is, cell for cell, the grid skimapd serves; the
// trajectory has every frame; a loop closure on pose_updates changes the map exactly as
// UpdatePoses does; the services answer; a frame the bridge cannot pose is counted, not
// sent.
#include <gtest/gtest.h>
#include <nav_msgs/MapMetaData.h>
#include <nav_msgs/OccupancyGrid.h>
#include <nav_msgs/Path.h>
#include <ros/ros.h>
#include <sensor_msgs/CompressedImage.h>
#include <signal.h>
#include <sys/wait.h>
#include <tf2_msgs/TFMessage.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <sstream>
#include <thread>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "client/map_client.h"
#include "skimap_ros/InstancesInBox.h"
#include "skimap_ros/InstancesInSphere.h"
#include "skimap_ros/SaveMap.h"
#include "tests/common/free_port.h"
#include "tests/common/skimapd_process.h"
#include "tests/common/spawn.h"
#include "tests/common/voxel_set.h"
#include "tests/ros/reference_voxels.h"
#include "tests/ros/ros_test_data.h"

namespace skimap::testing {
namespace {

namespace fs = std::filesystem;

bool WaitFor(const std::function<bool()>& done, double seconds) {
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(seconds);
  while (ros::WallTime::now() < end) {
    if (done()) return true;
    ros::WallDuration(0.05).sleep();
  }
  return done();
}

// One rosmaster for the whole test program, and this process as a ROS node.
class RosEnvironment : public ::testing::Environment {
 public:
  void SetUp() override {
    const int port = FreePort();
    uri_ = absl::StrCat("http://127.0.0.1:", port);
    setenv("ROS_MASTER_URI", uri_.c_str(), 1);
    setenv("ROS_IP", "127.0.0.1", 1);
    master_ = SpawnProcess(
        {"/usr/bin/python3", "/usr/bin/rosmaster", "--core", "-p", std::to_string(port)});
    ASSERT_GT(master_, 0);
    int argc = 0;
    ros::init(argc, nullptr, "skimap_ros_test", ros::init_options::NoSigintHandler);
    ASSERT_TRUE(WaitFor([] { return ros::master::check(); }, 30)) << "no rosmaster";
    spinner_ = std::make_unique<ros::AsyncSpinner>(2);
    spinner_->start();
  }
  void TearDown() override {
    spinner_.reset();
    ros::shutdown();
    kill(master_, SIGTERM);
    waitpid(master_, nullptr, 0);
  }

 private:
  std::string uri_;
  pid_t master_ = -1;
  std::unique_ptr<ros::AsyncSpinner> spinner_;
};

class BridgeTest : public ::testing::Test {
 protected:
  void SetUp() override {
    frames_ = LoadMmFrames(SKIMAP_YCBV_DIR);
    ASSERT_EQ(frames_.size(), 10u);
    dir_ = fs::temp_directory_path() / absl::StrCat("bridge_test_", getpid(), "_", ++runs_);
    fs::create_directories(dir_ / "saved");
    ASSERT_TRUE(server_.Start().ok());
    client_ = client::MapClient::Connect(server_.address());
    ns_ = absl::StrCat("/robot", runs_);
  }
  void TearDown() override {
    StopBridge();
    fs::remove_all(dir_);
  }

  // Starts skimap-ros in namespace ns_ on map `map`, with extra `_param:=value` args.
  void StartBridge(const std::string& map, std::vector<std::string> extra = {}) {
    std::vector<std::string> args = {
        SKIMAP_ROS_PATH,
        "__ns:=" + ns_,
        "__name:=skimap_ros",
        "_server:=" + (server_override_.empty() ? server_.address() : server_override_),
        "_map:=" + map,
        "_resolution:=0.02",
        "_fixed_frame:=world",
        "_tf_wait:=2.0",
        "_publish_rate:=5.0",
        "_save_dir:=" + (dir_ / "saved").string(),
        "_stats_file:=" + (dir_ / "stats.json").string(),
        "depth/image:=/cam/depth",
        "rgb/image:=/cam/rgb",
        "rgb/image/compressed:=/cam/rgb/compressed",
        "rgb/camera_info:=/cam/info",
        "depth/camera_info:=/cam/info"};
    args.insert(args.end(), extra.begin(), extra.end());
    SpawnOptions options;
    options.stdout_path = options.stderr_path = (dir_ / "bridge.log").string();
    bridge_ = SpawnProcess(args, options);
    ASSERT_GT(bridge_, 0);
  }
  // SIGINT, as rosnode kill / Ctrl-C; the exit status.
  // Makes frames_ `n` frames long: the real ones cycled, each with its own index and stamp.
  void CycleFramesTo(int n) {
    const std::vector<MmFrame> real = frames_;
    for (int i = int(real.size()); i < n; ++i) {
      MmFrame f = real[i % real.size()];
      f.index = i;
      f.stamp = ros::Time(1000.0 + i / 30.0);
      frames_.push_back(f);
    }
  }
  int StopBridge() {
    if (bridge_ <= 0) return -1;
    kill(bridge_, SIGINT);
    int status = -1;
    waitpid(bridge_, &status, 0);
    bridge_ = -1;
    return status;
  }
  std::string BridgeLog() {
    std::ifstream in(dir_ / "bridge.log");
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
  }

  // Publishes the frames at ~10 Hz once the bridge listens, tf first.
  // With `compressed`, colour goes as PNG (a sensor_msgs/CompressedImage).
  // `ready` runs once the bridge listens, before the first frame.
  void PublishFrames(ros::NodeHandle& nh, const std::vector<int>& skip_tf = {},
                     bool compressed = false, const std::function<void()>& ready = nullptr) {
    ros::Publisher depth = nh.advertise<sensor_msgs::Image>("/cam/depth", 10);
    ros::Publisher rgb = compressed
                             ? nh.advertise<sensor_msgs::CompressedImage>("/cam/rgb/compressed", 10)
                             : nh.advertise<sensor_msgs::Image>("/cam/rgb", 10);
    ros::Publisher info = nh.advertise<sensor_msgs::CameraInfo>("/cam/info", 10);
    ros::Publisher tf = nh.advertise<tf2_msgs::TFMessage>("/tf", 100);
    ros::Publisher tf_static = nh.advertise<tf2_msgs::TFMessage>("/tf_static", 1, true);
    ASSERT_TRUE(WaitFor(
        [&] {
          return depth.getNumSubscribers() > 0 &&
                 (!publish_color_ || rgb.getNumSubscribers() > 0) && info.getNumSubscribers() > 0 &&
                 tf.getNumSubscribers() > 0;
        },
        30))
        << BridgeLog();
    tf_static.publish(LinkToOptical());
    ros::WallDuration(0.5).sleep();
    if (ready) ready();
    for (const MmFrame& f : frames_) {
      if (std::find(skip_tf.begin(), skip_tf.end(), f.index) == skip_tf.end()) {
        tf.publish(WorldToLink(f));
      }
      ros::WallDuration(0.02).sleep();
      depth.publish(DepthMessage(f));
      if (!publish_color_) {
      } else if (compressed) {
        sensor_msgs::CompressedImage png;
        png.header = DepthMessage(f).header;
        png.format = "rgb8; png compressed bgr8";
        cv::Mat rgb_image(f.height, f.width, CV_8UC3, const_cast<uint8_t*>(f.rgb.data()));
        cv::Mat bgr;
        cv::cvtColor(rgb_image, bgr, cv::COLOR_RGB2BGR);
        cv::imencode(".png", bgr, png.data);
        rgb.publish(png);
      } else {
        rgb.publish(ColorMessage(f));
      }
      info.publish(InfoMessage(f));
      ros::WallDuration(0.1).sleep();
    }
  }

  uint64_t Frames(const std::string& map) {
    auto m = client_->GetMap("maps/" + map);
    return m.ok() ? m->stats().frames() : 0;
  }

  VoxelSet Reference(const std::string& id) { return ReferenceVoxels(*client_, frames_, id); }

  static inline int runs_ = 0;
  std::vector<MmFrame> frames_;
  fs::path dir_;
  std::string ns_;
  SkimapdProcess server_{SKIMAPD_PATH, {"--worker_threads=1"}};
  std::unique_ptr<client::MapClient> client_;
  pid_t bridge_ = -1;
  std::string server_override_;  // the bridge's ~server when not server_
  bool publish_color_ = true;    // false: depth and camera_info only
};

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
  std::ifstream stats(dir_ / "stats.json");
  std::stringstream text;
  text << stats.rdbuf();
  EXPECT_NE(text.str().find("\"acked\": 10"), std::string::npos) << text.str();
  EXPECT_NE(text.str().find("\"dropped\": 0"), std::string::npos) << text.str();
}

TEST_F(BridgeTest, CompressedColourMakesTheSameMap) {
  ros::NodeHandle nh;
  StartBridge("png", {"_compressed_color:=true"});
  PublishFrames(nh, {}, /*compressed=*/true);
  ASSERT_TRUE(WaitFor([&] { return Frames("png") == 10; }, 60)) << BridgeLog();
  EXPECT_EQ(Compare(Voxels(*client_, "maps/png"), Reference("png_ref")), "same");
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
  std::ifstream stats(dir_ / "stats.json");
  std::stringstream text;
  text << stats.rdbuf();
  EXPECT_NE(text.str().find("\"no_pose\": 1"), std::string::npos) << text.str();
  EXPECT_EQ(Frames("gaps"), 9u);
}

// skimapd stalls (SIGSTOP): the camera keeps publishing, the bridge keeps a bounded queue
// and drops the rest, counted; once skimapd resumes, what was in flight or queued is
// acknowledged and the map holds exactly the acknowledged frames.
TEST_F(BridgeTest, AStalledServerMakesTheBridgeDropAndCountNotQueue) {
  ros::NodeHandle nh;
  StartBridge("stall", {"_queue_frames:=2", "_window:=4"});
  CycleFramesTo(30);
  PublishFrames(nh, {}, false, [&] { server_.Signal(SIGSTOP); });
  ros::WallDuration(1.0).sleep();
  server_.Signal(SIGCONT);
  ros::WallDuration(3.0).sleep();
  EXPECT_EQ(StopBridge(), 0) << BridgeLog();
  std::ifstream stats(dir_ / "stats.json");
  std::stringstream text;
  text << stats.rdbuf();
  const std::string json = text.str();
  const auto number = [&](const std::string& key) {
    const size_t at = json.find("\"" + key + "\": ");
    return at == std::string::npos ? -1 : std::atoi(json.c_str() + at + key.size() + 4);
  };
  EXPECT_EQ(number("offered"), 30) << json;
  // At most the window, the queue and the frame the sender holds get through.
  EXPECT_GE(number("dropped"), 30 - 4 - 2 - 1) << json;
  EXPECT_EQ(number("acked") + number("dropped"), 30) << json;
  EXPECT_EQ(Frames("stall"), uint64_t(number("acked")));
}

// skimapd dies (kill -9) and comes back on the same port: the bridge reopens its stream
// and the frames after the restart are acknowledged; those in flight at the crash are
// counted as lost, never acknowledged.
TEST_F(BridgeTest, TheBridgeReconnectsAfterSkimapdRestarts) {
  const int port = FreePort();
  const std::string address = absl::StrCat("127.0.0.1:", port);
  const std::string data = (dir_ / "own").string();
  const auto start = [&] {
    return SpawnProcess({SKIMAPD_PATH, "--address=" + address, "--data_dir=" + data,
                         "--http_address=", "--worker_threads=1"});
  };
  pid_t own = start();
  auto own_client = client::MapClient::Connect(address);
  ASSERT_TRUE(own_client->WaitForServer(absl::Seconds(20)).ok());
  ros::NodeHandle nh;
  server_override_ = address;
  StartBridge("again");
  const std::vector<MmFrame> all = frames_;
  frames_.assign(all.begin(), all.begin() + 5);
  PublishFrames(nh);
  const auto frames = [&] {
    auto m = own_client->GetMap("maps/again");
    return m.ok() ? m->stats().frames() : 0;
  };
  ASSERT_TRUE(WaitFor([&] { return frames() == 5; }, 30)) << BridgeLog();
  kill(own, SIGKILL);
  waitpid(own, nullptr, 0);
  own = start();
  ASSERT_TRUE(own_client->WaitForServer(absl::Seconds(20)).ok());
  // The journal kept every acknowledged frame.
  ASSERT_TRUE(WaitFor([&] { return frames() == 5; }, 20));
  frames_.assign(all.begin() + 5, all.end());
  // The first frames after the crash may go to the dead stream (lost) before the bridge
  // notices; publish until frames after the restart are acknowledged.
  for (int round = 0; round < 5 && frames() < 6; ++round) {
    PublishFrames(nh);
    WaitFor([&] { return frames() >= 6; }, 3);
  }
  EXPECT_GE(frames(), 6u) << BridgeLog();
  EXPECT_EQ(StopBridge(), 0) << BridgeLog();
  std::ifstream stats(dir_ / "stats.json");
  std::stringstream text;
  text << stats.rdbuf();
  EXPECT_NE(text.str().find("\"acked\": "), std::string::npos);
  kill(own, SIGTERM);
  waitpid(own, nullptr, 0);
}

TEST_F(BridgeTest, ABadParameterStopsTheBridgeWithItsName) {
  for (const auto& [arg, message] : std::vector<std::pair<std::string, std::string>>{
           {"_depth_encoding:=jpeg", "~depth_encoding: \"jpeg\""},
           {"_shutdown_timeout:=0.0", "~shutdown_timeout: 0 must be a finite number > 0"}}) {
    StartBridge("bad", {arg});
    int status = -1;
    waitpid(bridge_, &status, 0);
    bridge_ = -1;
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 1) << arg;
    EXPECT_NE(BridgeLog().find(message), std::string::npos) << BridgeLog();
  }
}

// skimapd stops reading for good (SIGSTOP, a hung host) while frames are in flight: SIGINT
// still ends the node, after its wait for the acks (10 s) and ~shutdown_timeout for the
// stream, with status 2 and its report written.
TEST_F(BridgeTest, AHungSkimapdDoesNotHoldTheNodesShutdown) {
  ros::NodeHandle nh;
  StartBridge("hung", {"_queue_frames:=2", "_window:=4", "_shutdown_timeout:=2.0"});
  CycleFramesTo(30);
  PublishFrames(nh, {}, false, [&] { server_.Signal(SIGSTOP); });
  ros::WallDuration(1.0).sleep();
  const auto start = std::chrono::steady_clock::now();
  const int status = StopBridge();
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  server_.Signal(SIGCONT);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 2) << status << BridgeLog();
  EXPECT_LT(seconds, 10 + 2 + 10) << BridgeLog();
  EXPECT_NE(BridgeLog().find("did not release the stream within 2.0 s"), std::string::npos)
      << BridgeLog();
  std::ifstream stats(dir_ / "stats.json");
  std::stringstream text;
  text << stats.rdbuf();
  EXPECT_NE(text.str().find("\"offered\": 30"), std::string::npos) << text.str();
}

}  // namespace
}  // namespace skimap::testing

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ::testing::AddGlobalTestEnvironment(new skimap::testing::RosEnvironment);
  return RUN_ALL_TESTS();
}
