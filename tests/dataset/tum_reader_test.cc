// TUM RGB-D association and error reporting.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "dataset/reader.h"

namespace skimap::dataset {
namespace {

namespace fs = std::filesystem;

TEST(TumReaderTest, AssociatesNearestDepthAndPose) {
  const fs::path dir = fs::temp_directory_path() / ("tum_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  std::ofstream(dir / "rgb.txt") << "# comment\n1.000 rgb/a.png\n1.100 rgb/b.png\n5.0 rgb/c.png\n";
  std::ofstream(dir / "depth.txt") << "1.011 depth/a.png\n1.095 depth/b.png\n";
  std::ofstream(dir / "groundtruth.txt") << "1.001 1 2 3 0 0 0 1\n1.2 0 0 0 0 0 1 0\n";
  auto seq = LoadTumSequence(dir.string());
  ASSERT_TRUE(seq.ok()) << seq.status();
  ASSERT_EQ(seq->frames.size(), 2u);  // c.png has no depth within 20 ms
  EXPECT_EQ(seq->frames[0].depth_path, (dir / "depth/a.png").string());
  EXPECT_EQ(seq->frames[1].depth_path, (dir / "depth/b.png").string());
  EXPECT_TRUE(seq->frames[0].has_pose);
  EXPECT_DOUBLE_EQ(seq->frames[0].T_wc.translation().y(), 2.0);
  EXPECT_FALSE(seq->frames[1].has_pose);  // nearest pose is 100 ms away
  EXPECT_DOUBLE_EQ(seq->frames[0].depth_scale, 0.2);

  std::ofstream(dir / "groundtruth.txt") << "1.0 1 2 3 0 0\n";
  auto bad = LoadTumSequence(dir.string());
  EXPECT_EQ(bad.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(bad.status().message().find("groundtruth.txt:1"), std::string::npos);
  fs::remove_all(dir);
}

TEST(TumReaderTest, LoadSequenceRejectsUnknownFolder) {
  auto seq = LoadSequence("/nonexistent-folder");
  EXPECT_EQ(seq.status().code(), absl::StatusCode::kNotFound);
}

}  // namespace
}  // namespace skimap::dataset
