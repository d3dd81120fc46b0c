// The skimap-ros tests' world (bridge_test.cc, bridge_robustness_test.cc): one rosmaster
// for the test program (RosEnvironment, registered by bridge_test.cc's main) and, per test,
// a skimapd, the bridge as a process in its own namespace, and this process publishing the
// real YCB-Video frames (depth, colour, camera_info) with tf.
#ifndef TESTS_ROS_BRIDGE_FIXTURE_H_
#define TESTS_ROS_BRIDGE_FIXTURE_H_

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
#include "tests/common/images.h"
#include "tests/common/skimapd_process.h"
#include "tests/common/spawn.h"
#include "tests/common/voxel_set.h"
#include "tests/ros/reference_voxels.h"
#include "tests/ros/ros_test_data.h"

namespace skimap::testing {

namespace fs = std::filesystem;

inline bool WaitFor(const std::function<bool()>& done, double seconds) {
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
        "depth/image/compressedDepth:=/cam/depth/compressedDepth",
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
  // SIGINT, as rosnode kill / Ctrl-C; the exit status.
  int StopBridge() {
    if (bridge_ <= 0) return -1;
    kill(bridge_, SIGINT);
    int status = -1;
    waitpid(bridge_, &status, 0);
    bridge_ = -1;
    return status;
  }
  std::string BridgeLog() { return ReadFile(dir_ / "bridge.log"); }
  // The report the bridge writes at exit (~stats_file): counters and latencies as JSON.
  std::string StatsJson() { return ReadFile(dir_ / "stats.json"); }
  static std::string ReadFile(const fs::path& path) {
    std::ifstream in(path);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
  }

  // Publishes the frames at ~10 Hz once the bridge listens, tf first.
  // With `compressed`, colour goes as PNG (a sensor_msgs/CompressedImage).
  // `ready` runs once the bridge listens, before the first frame.
  void PublishFrames(ros::NodeHandle& nh, const std::vector<int>& skip_tf = {},
                     bool compressed = false, const std::function<void()>& ready = nullptr) {
    ros::Publisher depth =
        compressed_depth_.empty()
            ? nh.advertise<sensor_msgs::Image>("/cam/depth", 10)
            : nh.advertise<sensor_msgs::CompressedImage>("/cam/depth/compressedDepth", 10);
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
      if (compressed_depth_.empty()) {
        depth.publish(DepthMessage(f));
      } else {
        sensor_msgs::CompressedImage message = CompressedDepthMessage(f, compressed_depth_);
        if (edit_compressed_depth_) edit_compressed_depth_(f.index, &message);
        depth.publish(message);
      }
      if (!publish_color_) {
      } else if (compressed) {
        sensor_msgs::CompressedImage png;
        png.header = DepthMessage(f).header;
        png.format = "rgb8; png compressed bgr8";
        cv::Mat rgb_image(f.height, f.width, CV_8UC3, const_cast<uint8_t*>(f.rgb.data()));
        cv::Mat bgr;
        cv::cvtColor(rgb_image, bgr, cv::COLOR_RGB2BGR);
        ImEncode(".png", bgr, &png.data);
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
  std::string server_override_;   // the bridge's ~server when not server_
  bool publish_color_ = true;     // false: depth and camera_info only
  std::string compressed_depth_;  // "png" / "rvl": depth as compressedDepth with that codec
  // Changes frame i's compressedDepth message before it is published.
  std::function<void(int, sensor_msgs::CompressedImage*)> edit_compressed_depth_;
};

}  // namespace skimap::testing

#endif  // TESTS_ROS_BRIDGE_FIXTURE_H_
