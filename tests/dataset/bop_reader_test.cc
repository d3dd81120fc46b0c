// The BOP reader on the real YCB-Video sample in ../shared/data/ycbv-0000 (values from its
// README and JSON files) and on malformed inputs.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>

#include "dataset/reader.h"

namespace skimap::dataset {
namespace {

namespace fs = std::filesystem;

const std::string kYcbv = "../shared/data/ycbv-0000";

TEST(BopReaderTest, LoadsYcbvSampleCameraAndFrames) {
  auto ds = LoadBopDataset(kYcbv);
  ASSERT_TRUE(ds.ok()) << ds.status();
  ASSERT_TRUE(ds->camera.has_value());
  EXPECT_DOUBLE_EQ(ds->camera->K.fx, 1066.778);
  EXPECT_DOUBLE_EQ(ds->camera->depth_scale, 0.1);
  EXPECT_TRUE(ds->models.empty());  // the sample ships no models
  ASSERT_EQ(ds->scenes.count("test"), 1u);
  ASSERT_EQ(ds->scenes["test"].size(), 1u);

  auto seq = LoadBopScene(ds->scenes["test"][0]);
  ASSERT_TRUE(seq.ok()) << seq.status();
  ASSERT_EQ(seq->frames.size(), 10u);
  const Frame& f0 = seq->frames[0];
  EXPECT_EQ(f0.id, 0);  // 0-based ids
  EXPECT_EQ(f0.K.width, 640);
  EXPECT_EQ(f0.K.height, 480);
  EXPECT_DOUBLE_EQ(f0.K.cy, 241.3109);
  ASSERT_TRUE(f0.has_pose);
  // cam_t_w2c of image 0 is [56.12, 28.51, 603.12] mm: the camera centre is -R^T t.
  const Eigen::Isometry3d T_cw = f0.T_wc.inverse();
  // Tolerance 1e-6 m: the sample's rotations are orthonormal only to ~2e-6 (README).
  EXPECT_NEAR(T_cw.translation().z(), 0.60312362583522, 1e-6);
  EXPECT_NEAR(T_cw.linear()(1, 2), -0.787673, 1e-5);
  ASSERT_EQ(f0.objects.size(), 3u);
  EXPECT_EQ(f0.objects[0].obj_id, 8);
  EXPECT_EQ(f0.objects[1].obj_id, 14);
  EXPECT_EQ(f0.objects[2].obj_id, 21);
  EXPECT_EQ(f0.objects[0].px_count_visib, 18265);
  EXPECT_EQ(f0.objects[1].bbox_visib[0], 335);
}

TEST(BopReaderTest, YcbvObjectPoseInWorldIsStableAcrossFrames) {
  auto seq = LoadSequence(kYcbv + "/test/000000");
  ASSERT_TRUE(seq.ok()) << seq.status();
  // README: obj 8 mean t_m2w = [-87.26, 18.07, 32.14] mm, spread < 1 mm.
  for (const Frame& f : seq->frames) {
    const Eigen::Vector3d t = (f.T_wc * f.objects[0].T_m2c).translation() * 1e3;
    EXPECT_NEAR(t.x(), -87.26, 1.0);
    EXPECT_NEAR(t.y(), 18.07, 1.0);
    EXPECT_NEAR(t.z(), 32.14, 1.0);
  }
}

TEST(BopReaderTest, YcbvImagesMatchAnnotations) {
  auto seq = LoadBopScene(kYcbv + "/test/000000");
  ASSERT_TRUE(seq.ok()) << seq.status();
  const Frame& f = seq->frames[3];
  auto img = LoadFrameImages(f, /*load_masks=*/true);
  ASSERT_TRUE(img.ok()) << img.status();
  EXPECT_EQ(img->rgb.type(), CV_8UC3);
  EXPECT_EQ(img->depth.type(), CV_16UC1);
  ASSERT_EQ(img->masks.size(), 3u);
  for (size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(cv::countNonZero(img->masks[i]), f.objects[i].px_count_visib);
  }
  // README: valid depth 491-1569 mm (measured 2026-11-23: 494-1570 mm, at the bounds).
  cv::Mat m = DepthToMeters(img->depth, f.depth_scale);
  double lo, hi;
  cv::minMaxLoc(m, &lo, &hi, nullptr, nullptr, m > 0);
  EXPECT_GE(lo, 0.490);
  EXPECT_LE(hi, 1.570);
}

class BopReaderErrorTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("bop_err_" + std::to_string(::getpid()));
    fs::create_directories(dir_ / "scene");
  }
  void TearDown() override { fs::remove_all(dir_); }
  void Write(const std::string& name, const std::string& text) {
    std::ofstream(dir_ / name) << text;
  }
  fs::path dir_;
};

TEST_F(BopReaderErrorTest, MissingSceneCameraIsNotFound) {
  auto seq = LoadBopScene((dir_ / "scene").string());
  EXPECT_EQ(seq.status().code(), absl::StatusCode::kNotFound);
  EXPECT_NE(seq.status().message().find("scene_camera.json"), std::string::npos);
}

TEST_F(BopReaderErrorTest, BadJsonNamesTheFile) {
  Write("scene/scene_camera.json", "{\"0\": [1, 2");
  auto seq = LoadBopScene((dir_ / "scene").string());
  EXPECT_EQ(seq.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(seq.status().message().find("scene_camera.json"), std::string::npos);
}

TEST_F(BopReaderErrorTest, MissingFieldNamesTheField) {
  Write("camera.json", R"({"fx": 1, "fy": 1, "cx": 1, "cy": 1, "width": 4, "height": 3,
                           "depth_scale": 1})");
  Write("scene/scene_camera.json", R"({"0": {"cam_K": [1, 0, 1, 0, 1, 1, 0, 0, 1],
                                             "cam_R_w2c": [1, 0, 0, 0, 1, 0, 0, 0, 1]}})");
  auto seq = LoadBopScene((dir_ / "scene").string());
  EXPECT_EQ(seq.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(seq.status().message().find("cam_t_w2c"), std::string::npos) << seq.status();
}

TEST_F(BopReaderErrorTest, WrongImageSizeIsRejected) {
  Frame f;
  f.K = {1, 1, 1, 1, 640, 480};
  f.rgb_path = kYcbv + "/test/000000/rgb/000000.png";
  EXPECT_TRUE(LoadFrameImages(f).ok());
  f.K.width = 320;
  auto img = LoadFrameImages(f);
  EXPECT_EQ(img.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(img.status().message().find("640x480"), std::string::npos);
}

TEST_F(BopReaderErrorTest, ModelSymmetriesAreReadInMetresAndBadOnesNamed) {
  // Object 1: a half turn about z with a 10 mm shift; object 2: continuous about z through
  // (0, 0, 5) mm; object 3: none. (BOP models_info.json, millimetres.)
  Write("models_info.json", R"({
    "1": {"diameter": 100, "min_x": 0, "min_y": 0, "min_z": 0, "size_x": 1, "size_y": 1,
          "size_z": 1, "symmetries_discrete": [[-1, 0, 0, 10, 0, -1, 0, 0, 0, 0, 1, 0,
                                                0, 0, 0, 1]]},
    "2": {"diameter": 100, "min_x": 0, "min_y": 0, "min_z": 0, "size_x": 1, "size_y": 1,
          "size_z": 1, "symmetries_continuous": [{"axis": [0, 0, 1], "offset": [0, 0, 5]}]},
    "3": {"diameter": 100, "min_x": 0, "min_y": 0, "min_z": 0, "size_x": 1, "size_y": 1,
          "size_z": 1}})");
  auto models = LoadModelsInfo((dir_ / "models_info.json").string());
  ASSERT_TRUE(models.ok()) << models.status();
  ASSERT_EQ((*models)[1].symmetries.size(), 1u);
  const Eigen::Isometry3d& half = (*models)[1].symmetries[0];
  EXPECT_TRUE(half.linear().isApprox(
      Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitZ()).toRotationMatrix(), 1e-12));
  EXPECT_NEAR(half.translation().x(), 0.010, 1e-12);
  // 2-degree steps over the turn, the identity left out; points on the axis stay put.
  const std::vector<Eigen::Isometry3d>& turn = (*models)[2].symmetries;
  ASSERT_EQ(turn.size(), static_cast<size_t>(360 / kContinuousSymmetryStepDeg) - 1);
  for (const Eigen::Isometry3d& S : turn) {
    EXPECT_TRUE((S * Eigen::Vector3d(0, 0, 0.005)).isApprox(Eigen::Vector3d(0, 0, 0.005), 1e-12));
  }
  EXPECT_TRUE((*models)[3].symmetries.empty());
  Write("models_info.json", R"({"1": {"diameter": 100, "min_x": 0, "min_y": 0, "min_z": 0,
    "size_x": 1, "size_y": 1, "size_z": 1, "symmetries_discrete": [[1, 0, 0]]}})");
  models = LoadModelsInfo((dir_ / "models_info.json").string());
  EXPECT_EQ(models.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(models.status().message().find("symmetries_discrete[0]"), std::string::npos)
      << models.status();
  Write("models_info.json", R"({"1": {"diameter": 100, "min_x": 0, "min_y": 0, "min_z": 0,
    "size_x": 1, "size_y": 1, "size_z": 1,
    "symmetries_continuous": [{"axis": [0, 0, 0], "offset": [0, 0, 0]}]}})");
  models = LoadModelsInfo((dir_ / "models_info.json").string());
  EXPECT_EQ(models.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(models.status().message().find("axis"), std::string::npos) << models.status();
}

}  // namespace
}  // namespace skimap::dataset
