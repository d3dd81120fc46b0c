// BopSceneWriter + WriteBopCamera + WriteModelsInfo round-trip through the reader.
#include "dataset/writer.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "dataset/reader.h"
#include "tests/common/images.h"

namespace skimap::dataset {
namespace {

namespace fs = std::filesystem;

Eigen::Isometry3d Pose(double ax, double ay, double az, Eigen::Vector3d t) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = (Eigen::AngleAxisd(az, Eigen::Vector3d::UnitZ()) *
                Eigen::AngleAxisd(ay, Eigen::Vector3d::UnitY()) *
                Eigen::AngleAxisd(ax, Eigen::Vector3d::UnitX()))
                   .toRotationMatrix();
  T.translation() = t;
  return T;
}

TEST(BopWriterTest, SceneRoundTripsThroughReader) {
  const fs::path root = fs::temp_directory_path() / ("bop_rt_" + std::to_string(::getpid()));
  fs::remove_all(root);
  CameraInfo cam{{525, 526, 319.5, 239.5, 64, 48}, 0.2};
  fs::create_directories(root);
  ASSERT_TRUE(WriteBopCamera((root / "camera.json").string(), cam).ok());
  std::map<int, ModelInfo> models;
  models[3] = {3, 0.25, {-0.1, -0.05, 0}, {0.2, 0.1, 0.15}, ""};
  ASSERT_TRUE(WriteModelsInfo((root / "models_info.json").string(), models).ok());

  BopSceneWriter w((root / "test" / "000001").string());
  ASSERT_TRUE(w.Create().ok());
  for (int id = 2; id >= 0; --id) {  // any order
    Frame f;
    f.id = id;
    f.timestamp = id / 30.0;
    f.K = cam.K;
    f.depth_scale = cam.depth_scale;
    f.has_pose = true;
    f.T_wc = Pose(0.1 * id, -0.4, 2.0, {1.0 + id, -2.5, 1.3});
    ObjectAnnotation a;
    a.obj_id = 3;
    a.T_m2c = Pose(0.3, 0.2 * id, -1, {0.01, 0.02, 0.9 + id});
    a.bbox_visib = {1, 2, 3, 4};
    a.px_count_visib = 11;
    f.objects.push_back(a);
    w.AddFrame(f);
    skimap::testing::ImWrite(BopRgbPath(w.dir(), id),
                             cv::Mat(48, 64, CV_8UC3, cv::Scalar(1, 2, 3)));
    skimap::testing::ImWrite(BopDepthPath(w.dir(), id),
                             cv::Mat(48, 64, CV_16UC1, cv::Scalar(5000)));
  }
  ASSERT_TRUE(w.Finish().ok());

  auto ds = LoadBopDataset(root.string());
  ASSERT_TRUE(ds.ok()) << ds.status();
  ASSERT_EQ(ds->models.size(), 1u);
  EXPECT_NEAR(ds->models[3].diameter, 0.25, 1e-12);
  EXPECT_NEAR(ds->models[3].size.z(), 0.15, 1e-12);

  TumOptions tum;
  tum.K = cam.K;
  for (auto loaded : {LoadBopScene(w.dir()), LoadTumSequence(w.dir(), tum)}) {
    ASSERT_TRUE(loaded.ok()) << loaded.status();
    ASSERT_EQ(loaded->frames.size(), 3u);
    for (const Frame& f : loaded->frames) {
      const Eigen::Isometry3d want = Pose(0.1 * f.id, -0.4, 2.0, {1.0 + f.id, -2.5, 1.3});
      EXPECT_TRUE(f.T_wc.isApprox(want, 1e-6)) << f.id;
      auto img = LoadFrameImages(f);
      ASSERT_TRUE(img.ok()) << img.status();
      EXPECT_FLOAT_EQ(DepthToMeters(img->depth, f.depth_scale).at<float>(5, 5), 1.0f);
    }
  }
  auto seq = LoadBopScene(w.dir());
  EXPECT_EQ(seq->frames[1].K.height, 48);  // from camera.json two levels up
  ASSERT_EQ(seq->frames[1].objects.size(), 1u);
  EXPECT_TRUE(
      seq->frames[1].objects[0].T_m2c.isApprox(Pose(0.3, 0.2, -1, {0.01, 0.02, 1.9}), 1e-12));
  EXPECT_EQ(seq->frames[1].objects[0].px_count_visib, 11);
  fs::remove_all(root);
}

}  // namespace
}  // namespace skimap::dataset
