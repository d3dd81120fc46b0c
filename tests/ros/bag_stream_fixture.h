// The fixture of the `skimap stream BAG` tests (bag_stream_test.cc, ros1_bag_check_test.cc):
// a real skimapd, the ten ycbv-0000 frames as ROS messages, a ROS 1 bag of them written with
// the rosbag API, and the CLI run as a process.
#ifndef SKIMAP_TESTS_ROS_BAG_STREAM_FIXTURE_H_
#define SKIMAP_TESTS_ROS_BAG_STREAM_FIXTURE_H_

#include <gtest/gtest.h>
#include <rosbag/bag.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "client/map_client.h"
#include "tests/common/skimapd_process.h"
#include "tests/common/voxel_set.h"
#include "tests/ros/reference_voxels.h"
#include "tests/ros/ros_test_data.h"

namespace skimap::testing {

namespace fs = std::filesystem;

struct CommandRun {
  int status = -1;
  std::string output;  // stdout and stderr
};

inline CommandRun RunCommand(const std::string& command) {
  CommandRun r;
  FILE* p = popen((command + " 2>&1").c_str(), "r");
  if (p == nullptr) return r;
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof buf, p)) > 0) r.output.append(buf, n);
  r.status = pclose(p);
  return r;
}

class BagStreamTest : public ::testing::Test {
 protected:
  void SetUp() override {
    frames_ = LoadMmFrames(SKIMAP_YCBV_DIR);
    ASSERT_EQ(frames_.size(), 10u);
    dir_ = fs::temp_directory_path() / absl::StrCat("bag_stream_test_", getpid());
    fs::create_directories(dir_);
    ASSERT_TRUE(server_.Start().ok());
    client_ = client::MapClient::Connect(server_.address());
  }
  void TearDown() override { fs::remove_all(dir_); }

  VoxelSet Reference(const std::string& id) { return ReferenceVoxels(*client_, frames_, id); }

  CommandRun Stream(const std::string& bag, const std::string& map, const std::string& flags = "") {
    return RunCommand(absl::StrCat(SKIMAP_CLI_PATH, " --server=", server_.address(), " stream ",
                                   bag, " --map=", map, " --resolution=0.02 ", flags));
  }

  uint64_t Frames(const std::string& map) {
    auto m = client_->GetMap("maps/" + map);
    return m.ok() ? m->stats().frames() : 0;
  }

  // Writes a ROS 1 bag of the frames; `edit` may change each frame's messages.
  std::string WriteRos1Bag(
      const std::string& name,
      const std::function<void(int, sensor_msgs::Image*, sensor_msgs::Image*)>& edit = nullptr,
      bool with_info = true) {
    const std::string path = (dir_ / name).string();
    rosbag::Bag bag(path, rosbag::bagmode::Write);
    bag.write("/tf_static", ros::Time(1000.0), LinkToOptical());
    for (const MmFrame& f : frames_) {
      sensor_msgs::Image depth = DepthMessage(f), color = ColorMessage(f);
      if (edit) edit(f.index, &depth, &color);
      bag.write("/tf", f.stamp, WorldToLink(f));
      if (with_info) bag.write("/camera/color/camera_info", f.stamp, InfoMessage(f));
      bag.write("/camera/aligned_depth_to_color/image_raw", f.stamp, depth);
      bag.write("/camera/color/image_raw", f.stamp, color);
    }
    bag.close();
    return path;
  }

  std::vector<MmFrame> frames_;
  fs::path dir_;
  SkimapdProcess server_{SKIMAPD_PATH, {"--worker_threads=1"}};
  std::unique_ptr<client::MapClient> client_;
};

}  // namespace skimap::testing

#endif  // SKIMAP_TESTS_ROS_BAG_STREAM_FIXTURE_H_
