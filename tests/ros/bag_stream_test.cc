// `skimap stream BAG` end to end: a ROS 1 bag written with the rosbag C++ API and ROS 2
// MCAP bags written by an independent writer (npm's @mcap/core with
// @foxglove/rosmsg2-serialization: tests/ros/mcap_writer) from the real YCB-Video frames,
// streamed by the CLI into a real skimapd: the map holds exactly the voxels of the same
// frames sent as API frames (tests/ros/ros_test_data.h). ROS 2 bags in rosbag2's older
// sqlite3 storage: the same writer's CDR messages stored by Python's sqlite3 module
// (tests/ros/write_db3.py). Hostile bags: truncated, an
// image whose size does not match its data, an unsupported encoding, no camera_info, an
// ambiguous topic choice: refused by name, the map holds only what was acknowledged. ROS 1
// bags that crash or stall Debian's rosbag: ros1_bag_check_test.cc.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>

#include "absl/strings/str_cat.h"
#include "tests/common/images.h"
#include "tests/ros/bag_stream_fixture.h"

namespace skimap::testing {
namespace {

TEST_F(BagStreamTest, Ros1BagStreamsTheVoxelsOfItsFrames) {
  const std::string bag = WriteRos1Bag("frames.bag");
  const CommandRun run = Stream(bag, "ros1");
  ASSERT_EQ(run.status, 0) << run.output;
  EXPECT_NE(run.output.find("streamed 10 frames"), std::string::npos) << run.output;
  // The topics and frames it chose by itself, named.
  EXPECT_NE(run.output.find("/camera/aligned_depth_to_color/image_raw"), std::string::npos);
  EXPECT_NE(run.output.find("poses in world"), std::string::npos) << run.output;
  const VoxelSet streamed = Voxels(*client_, "maps/ros1");
  const VoxelSet reference = Reference("ros1_ref");
  EXPECT_GT(reference.size(), 900u);  // 1 363 voxels at 2 cm (2026-11-28)
  EXPECT_EQ(Compare(streamed, reference), "same");
}

TEST_F(BagStreamTest, CompressedDepthBagsStreamTheVoxelsOfTheirFrames) {
  // image_transport's compressedDepth (PNG and RVL) on the depth topic's /compressedDepth,
  // as `rosbag record` of a RealSense or OpenNI driver over that transport stores it.
  const VoxelSet reference = Reference("cd_ref");
  const std::string depth = "/camera/aligned_depth_to_color/image_raw";
  struct Variant {
    std::string name, codec;
    bool raw_twin;  // the raw depth topic recorded too
    std::string expect;
  };
  for (const Variant& v : std::vector<Variant>{
           // camera_info beside the depth topic's folder, found through /compressedDepth
           {"png", "png", false,
            "bag: depth " + depth +
                "/compressedDepth, colour /camera/color/image_raw, "
                "camera_info /camera/aligned_depth_to_color/camera_info"},
           // a depth-named JPEG topic (image_transport's `compressed` of a depth image, which
           // holds no depth) is no candidate
           {"rvl", "rvl", false, "bag: depth " + depth + "/compressedDepth, "},
           // a raw topic and its twin: the raw one
           {"twin", "rvl", true, "bag: depth " + depth + ", "}}) {
    SCOPED_TRACE(v.name);
    const std::string path = (dir_ / ("cd_" + v.name + ".bag")).string();
    {
      rosbag::Bag bag(path, rosbag::bagmode::Write);
      bag.write("/tf_static", ros::Time(1000.0), LinkToOptical());
      for (const MmFrame& f : frames_) {
        bag.write("/tf", f.stamp, WorldToLink(f));
        bag.write(v.name == "png" ? "/camera/aligned_depth_to_color/camera_info"
                                  : "/camera/color/camera_info",
                  f.stamp, InfoMessage(f));
        bag.write(depth + "/compressedDepth", f.stamp, CompressedDepthMessage(f, v.codec));
        if (v.raw_twin) bag.write(depth, f.stamp, DepthMessage(f));
        if (v.name == "rvl") {
          sensor_msgs::CompressedImage jpeg;
          jpeg.header = DepthMessage(f).header;
          jpeg.format = "16UC1; jpeg compressed mono8";
          ImEncode(".jpg", cv::Mat(8, 8, CV_8UC1, cv::Scalar(7)), &jpeg.data);
          bag.write("/camera/depth_registered/image_raw/compressed", f.stamp, jpeg);
        }
        bag.write("/camera/color/image_raw", f.stamp, ColorMessage(f));
      }
    }
    const std::string map = "cd_" + v.name;
    const CommandRun run = Stream(path, map);
    ASSERT_EQ(run.status, 0) << run.output;
    EXPECT_NE(run.output.find(v.expect), std::string::npos) << run.output;
    EXPECT_EQ(Compare(Voxels(*client_, "maps/" + map), reference), "same");
  }
}

// The fraction of `a`'s voxel centres that are also in `b`.
double Shared(const VoxelSet& a, const VoxelSet& b) {
  std::set<std::tuple<double, double, double>> centres;
  for (const auto& v : b) centres.insert({std::get<0>(v), std::get<1>(v), std::get<2>(v)});
  size_t shared = 0;
  for (const auto& v : a) shared += centres.count({std::get<0>(v), std::get<1>(v), std::get<2>(v)});
  return a.empty() ? 0 : double(shared) / a.size();
}

TEST_F(BagStreamTest, ALensDistortionIsUndoneBeforeFramesAreSent) {
  // The frames as a camera with a wide-angle lens saw them, its camera_info saying so;
  // streamed, they must land where the pinhole frames do.
  const VoxelSet reference = Reference("lens_ref");
  std::vector<MmFrame> distorted;
  for (const MmFrame& f : frames_) distorted.push_back(Distorted(f));
  const auto write = [&](const std::string& name, const std::vector<double>& D) {
    const std::string path = (dir_ / name).string();
    rosbag::Bag bag(path, rosbag::bagmode::Write);
    bag.write("/tf_static", ros::Time(1000.0), LinkToOptical());
    for (const MmFrame& f : distorted) {
      sensor_msgs::CameraInfo info = InfoMessage(f);
      info.D = D;
      bag.write("/tf", f.stamp, WorldToLink(f));
      bag.write("/camera/color/camera_info", f.stamp, info);
      bag.write("/camera/aligned_depth_to_color/image_raw", f.stamp, DepthMessage(f));
      bag.write("/camera/color/image_raw", f.stamp, ColorMessage(f));
    }
    return path;
  };
  const CommandRun run = Stream(write("lens.bag", LensDistortion()), "lens");
  ASSERT_EQ(run.status, 0) << run.output;
  // The same images with the distortion left out of camera_info: taken as pinhole.
  const CommandRun naive = Stream(write("naive.bag", std::vector<double>(5, 0.0)), "naive");
  ASSERT_EQ(naive.status, 0) << naive.output;
  const VoxelSet rectified = Voxels(*client_, "maps/lens"),
                 pinhole = Voxels(*client_, "maps/naive");
  std::printf(
      "voxels shared with the pinhole frames': rectified %.3f (%zu voxels), distorted "
      "taken as pinhole %.3f (%zu), reference %zu\n",
      Shared(rectified, reference), rectified.size(), Shared(pinhole, reference), pinhole.size(),
      reference.size());
  // 2026-11-29: 0.972 of the rectified frames' voxels are the pinhole frames', 0.912 of the
  // distorted frames' taken as pinhole (the scene is near and smooth: most of a frame's
  // displacement stays inside a 2 cm voxel).
  EXPECT_GT(Shared(rectified, reference), 0.95);
  EXPECT_LT(Shared(pinhole, reference), Shared(rectified, reference) - 0.03);
}

TEST_F(BagStreamTest, EveryAndMaxFramesApplyToBags) {
  const std::string bag = WriteRos1Bag("frames.bag");
  const CommandRun run = Stream(bag, "some", "--every=3 --max_frames=3");
  ASSERT_EQ(run.status, 0) << run.output;
  EXPECT_EQ(Frames("some"), 3u);
}

TEST_F(BagStreamTest, McapBagsOfAnIndependentWriterStreamTheVoxelsOfTheirFrames) {
  const VoxelSet reference = Reference("mcap_ref");
  const std::vector<std::pair<std::string, std::string>> variants = {
      {"zstd", "--compression zstd"},
      {"lz4", "--compression lz4"},
      {"plain", "--compression none --unchunked"},
      {"png", "--compression zstd --color compressed"},
      {"float", "--compression zstd --depth-format 32FC1"},
  };
  for (const auto& [name, flags] : variants) {
    SCOPED_TRACE(name);
    const std::string bag = (dir_ / (name + ".mcap")).string();
    const CommandRun write = RunCommand(
        absl::StrCat("node ", SKIMAP_MCAP_WRITER, " ", SKIMAP_YCBV_DIR, " ", bag, " ", flags));
    ASSERT_EQ(write.status, 0) << write.output;
    const CommandRun run = Stream(bag, name);
    ASSERT_EQ(run.status, 0) << run.output;
    EXPECT_EQ(Compare(Voxels(*client_, "maps/" + name), reference), "same");
  }
}

TEST_F(BagStreamTest, Sqlite3BagsOfAnIndependentWriterStreamTheVoxelsOfTheirFrames) {
  const VoxelSet reference = Reference("db3_ref");
  const std::string jsonl = (dir_ / "messages.jsonl").string();
  const CommandRun write =
      RunCommand(absl::StrCat("node ", SKIMAP_MCAP_WRITER, " ", SKIMAP_YCBV_DIR, " ",
                              (dir_ / "db3.mcap").string(), " --jsonl ", jsonl));
  ASSERT_EQ(write.status, 0) << write.output;
  // One .db3 in a rosbag2 folder; a recording split over three; the .db3 file alone.
  for (const auto& [name, split] : std::vector<std::pair<std::string, std::string>>{
           {"db3one", ""}, {"db3split", " --split 20"}}) {
    SCOPED_TRACE(name);
    const std::string folder = (dir_ / name).string();
    const CommandRun convert =
        RunCommand(absl::StrCat("python3 ", SKIMAP_DB3_WRITER, " ", jsonl, " ", folder, split));
    ASSERT_EQ(convert.status, 0) << convert.output;
    const CommandRun run = Stream(folder, name);
    ASSERT_EQ(run.status, 0) << run.output;
    EXPECT_NE(run.output.find("streamed 10 frames"), std::string::npos) << run.output;
    EXPECT_EQ(Compare(Voxels(*client_, "maps/" + name), reference), "same");
  }
  EXPECT_TRUE(fs::exists(dir_ / "db3split" / "db3split_2.db3"));
  const CommandRun file = Stream((dir_ / "db3one" / "db3one_0.db3").string(), "db3file");
  ASSERT_EQ(file.status, 0) << file.output;
  EXPECT_EQ(Compare(Voxels(*client_, "maps/db3file"), reference), "same");
  // Immutable, read-only: nothing was written beside the database.
  EXPECT_FALSE(fs::exists(dir_ / "db3one" / "db3one_0.db3-journal"));
  EXPECT_FALSE(fs::exists(dir_ / "db3one" / "db3one_0.db3-wal"));
}

TEST_F(BagStreamTest, CorruptSqlite3BagsAreRefusedByNameAndNeverCrashTheCli) {
  const std::string jsonl = (dir_ / "messages.jsonl").string();
  ASSERT_EQ(RunCommand(absl::StrCat("node ", SKIMAP_MCAP_WRITER, " ", SKIMAP_YCBV_DIR, " ",
                                    (dir_ / "x.mcap").string(), " --limit 3 --jsonl ", jsonl))
                .status,
            0);
  const fs::path folder = dir_ / "good";
  ASSERT_EQ(
      RunCommand(absl::StrCat("python3 ", SKIMAP_DB3_WRITER, " ", jsonl, " ", folder.string()))
          .status,
      0);
  std::string bytes;
  {
    std::ifstream in(folder / "good_0.db3", std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), {});
  }
  ASSERT_GT(bytes.size(), 8192u);
  // Truncated at several places, and pages overwritten with random bytes: each run ends
  // with an error naming the file or streams what it could read, and the CLI never dies of
  // a signal.
  std::mt19937 rng(7);
  for (int i = 0; i < 12; ++i) {
    SCOPED_TRACE(i);
    std::string damaged = bytes;
    if (i < 4) {
      damaged.resize(bytes.size() * (i + 1) / 5);
    } else {
      const size_t at = 100 + rng() % (bytes.size() - 1100);
      for (size_t k = 0; k < 1000; ++k) damaged[at + k] = static_cast<char>(rng());
    }
    const std::string path = (dir_ / absl::StrCat("bad", i, ".db3")).string();
    std::ofstream(path, std::ios::binary) << damaged;
    const CommandRun run = Stream(path, absl::StrCat("bad", i));
    ASSERT_TRUE(WIFEXITED(run.status)) << run.output;
    if (WEXITSTATUS(run.status) != 0) {
      EXPECT_NE(run.output.find(absl::StrCat("bad", i, ".db3")), std::string::npos) << run.output;
    }
  }
  // A database that is not a rosbag2 bag.
  const std::string other = (dir_ / "other.db3").string();
  ASSERT_EQ(RunCommand(absl::StrCat("python3 -c \"import sqlite3; "
                                    "sqlite3.connect('",
                                    other, "').execute('CREATE TABLE t(x)')\""))
                .status,
            0);
  const CommandRun run = Stream(other, "other");
  EXPECT_NE(run.status, 0);
  EXPECT_NE(run.output.find("other.db3: not a rosbag2 sqlite3 bag"), std::string::npos)
      << run.output;
}

TEST_F(BagStreamTest, ATruncatedBagStopsWithTheFramesBeforeTheDamage) {
  const std::string whole = WriteRos1Bag("whole.bag");
  const std::string cut = (dir_ / "cut.bag").string();
  fs::copy_file(whole, cut);
  fs::resize_file(cut, fs::file_size(whole) / 2);
  const CommandRun run = Stream(cut, "cut");
  EXPECT_NE(run.status, 0) << run.output;
  EXPECT_NE(run.output.find("cut.bag"), std::string::npos) << run.output;
  EXPECT_LT(Frames("cut"), 10u);
  EXPECT_TRUE(server_.Running());

  // The same for an MCAP bag cut in its data section.
  const std::string mcap = (dir_ / "whole.mcap").string();
  ASSERT_EQ(RunCommand(absl::StrCat("node ", SKIMAP_MCAP_WRITER, " ", SKIMAP_YCBV_DIR, " ", mcap,
                                    " --compression zstd"))
                .status,
            0);
  const std::string mcap_cut = (dir_ / "cut.mcap").string();
  fs::copy_file(mcap, mcap_cut);
  fs::resize_file(mcap_cut, fs::file_size(mcap) * 2 / 3);
  const CommandRun mcap_run = Stream(mcap_cut, "mcap_cut");
  EXPECT_NE(mcap_run.status, 0) << mcap_run.output;
  EXPECT_NE(mcap_run.output.find("cut.mcap"), std::string::npos) << mcap_run.output;
  EXPECT_LT(Frames("mcap_cut"), 10u);
}

TEST_F(BagStreamTest, AnImageNotMatchingItsDataIsRefusedByTopicAndTheRestStreams) {
  const std::string bag =
      WriteRos1Bag("short.bag", [](int i, sensor_msgs::Image* depth, sensor_msgs::Image*) {
        if (i == 4) depth->data.resize(1000);
      });
  const CommandRun run = Stream(bag, "short");
  EXPECT_NE(run.status, 0) << run.output;
  EXPECT_NE(run.output.find("/camera/aligned_depth_to_color/image_raw: data holds 1000 bytes"),
            std::string::npos)
      << run.output;
  EXPECT_EQ(Frames("short"), 9u);
}

TEST_F(BagStreamTest, AnUnsupportedEncodingIsNamed) {
  const std::string bag = WriteRos1Bag(
      "yuv.bag",
      [](int, sensor_msgs::Image*, sensor_msgs::Image* color) { color->encoding = "yuv422"; });
  const CommandRun run = Stream(bag, "yuv");
  EXPECT_NE(run.status, 0);
  EXPECT_NE(run.output.find("/camera/color/image_raw: colour encoding \"yuv422\""),
            std::string::npos)
      << run.output;
  EXPECT_EQ(Frames("yuv"), 0u);
}

TEST_F(BagStreamTest, ABagWithoutCameraInfoIsRefusedBeforeStreaming) {
  const std::string bag = WriteRos1Bag("noinfo.bag", nullptr, /*with_info=*/false);
  const CommandRun run = Stream(bag, "noinfo");
  EXPECT_NE(run.status, 0);
  EXPECT_NE(run.output.find("camera_info"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("--camera_info_topic"), std::string::npos) << run.output;
}

TEST_F(BagStreamTest, TwoDepthTopicsAskForTheFlagAndTheFlagChooses) {
  const std::string path = (dir_ / "two.bag").string();
  {
    rosbag::Bag bag(path, rosbag::bagmode::Write);
    bag.write("/tf_static", ros::Time(1000.0), LinkToOptical());
    for (const MmFrame& f : frames_) {
      bag.write("/tf", f.stamp, WorldToLink(f));
      bag.write("/front/depth/image_raw", f.stamp, DepthMessage(f));
      bag.write("/back/depth/image_raw", f.stamp, DepthMessage(f));
      bag.write("/front/depth/camera_info", f.stamp, InfoMessage(f));
      bag.write("/back/depth/camera_info", f.stamp, InfoMessage(f));
    }
  }
  const CommandRun ambiguous = Stream(path, "two");
  EXPECT_NE(ambiguous.status, 0);
  EXPECT_NE(ambiguous.output.find("/back/depth/image_raw, /front/depth/image_raw"),
            std::string::npos)
      << ambiguous.output;
  EXPECT_NE(ambiguous.output.find("--depth_topic"), std::string::npos);
  const CommandRun chosen = Stream(path, "two", "--depth_topic=/front/depth/image_raw");
  ASSERT_EQ(chosen.status, 0) << chosen.output;
  EXPECT_EQ(Frames("two"), 10u);
  EXPECT_NE(chosen.output.find("colour (none)"), std::string::npos) << chosen.output;
}

TEST_F(BagStreamTest, NotABagIsRefusedByName) {
  const std::string path = (dir_ / "junk.bag").string();
  std::ofstream(path) << "this is not a bag";
  const CommandRun run = Stream(path, "junk");
  EXPECT_NE(run.status, 0);
  EXPECT_NE(run.output.find("junk.bag: neither a ROS 1 bag"), std::string::npos) << run.output;
}

}  // namespace
}  // namespace skimap::testing
