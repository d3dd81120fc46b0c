// client/cli/single_view.h: PnP RANSAC from 2D-3D matches recovers a known pose among
// outliers, refuses too few inliers, and a scene keeps each object's best view.
#include "client/cli/single_view.h"

#include <gtest/gtest.h>

#include <random>

namespace skimap::client {
namespace {

const dataset::Intrinsics kK{
    .fx = 525, .fy = 525, .cx = 319.5, .cy = 239.5, .width = 640, .height = 480};

Eigen::Isometry3d Pose(double angle_deg, const Eigen::Vector3d& axis, const Eigen::Vector3d& t) {
  Eigen::Isometry3d p = Eigen::Isometry3d::Identity();
  p.linear() = Eigen::AngleAxisd(angle_deg * M_PI / 180, axis.normalized()).toRotationMatrix();
  p.translation() = t;
  return p;
}

// `inliers` exact matches of points on a 10 cm box seen at T_cm, then `outliers` matches
// whose model point is random and pixel anywhere in the image.
void AddMatches(int obj_id, const Eigen::Isometry3d& T_cm, int inliers, int outliers,
                std::mt19937* rng, google::protobuf::RepeatedPtrField<v1::FeatureMatch>* out) {
  std::uniform_real_distribution<double> model(-0.05, 0.05), u(0, 640), v(0, 480);
  for (int i = 0; i < inliers + outliers; ++i) {
    const Eigen::Vector3d p(model(*rng), model(*rng), model(*rng));
    v1::FeatureMatch& m = *out->Add();
    m.set_obj_id(obj_id);
    m.mutable_model_point()->set_x(p.x());
    m.mutable_model_point()->set_y(p.y());
    m.mutable_model_point()->set_z(p.z());
    if (i < inliers) {
      const Eigen::Vector3d c = T_cm * p;
      m.set_x(static_cast<float>(kK.fx * c.x() / c.z() + kK.cx));
      m.set_y(static_cast<float>(kK.fy * c.y() / c.z() + kK.cy));
    } else {
      m.set_x(static_cast<float>(u(*rng)));
      m.set_y(static_cast<float>(v(*rng)));
    }
  }
}

double AngleDeg(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return Eigen::Quaterniond(a.linear()).angularDistance(Eigen::Quaterniond(b.linear())) * 180 /
         M_PI;
}

TEST(SingleViewTest, PnpRansacRecoversAKnownPoseAmongHalfOutliers) {
  std::mt19937 rng(7);
  const Eigen::Isometry3d truth = Pose(35, {1, 2, 0.5}, {0.1, -0.05, 0.8});
  google::protobuf::RepeatedPtrField<v1::FeatureMatch> matches;
  AddMatches(3, truth, 30, 30, &rng, &matches);
  const std::vector<SingleViewPose> poses = EstimateSingleViewPoses(matches, kK, {});
  ASSERT_EQ(poses.size(), 1u);
  EXPECT_EQ(poses[0].obj_id, 3);
  EXPECT_EQ(poses[0].matches, 60);
  EXPECT_GE(poses[0].inliers, 30);
  EXPECT_LE(poses[0].inliers, 33);  // a random outlier may land within 8 px by chance
  EXPECT_LT((poses[0].T_cm.translation() - truth.translation()).norm(), 1e-3);
  EXPECT_LT(AngleDeg(poses[0].T_cm, truth), 0.5);
  // Deterministic: the same matches give the same pose.
  const std::vector<SingleViewPose> again = EstimateSingleViewPoses(matches, kK, {});
  ASSERT_EQ(again.size(), 1u);
  EXPECT_TRUE(again[0].T_cm.isApprox(poses[0].T_cm));
}

TEST(SingleViewTest, TooFewInliersGiveNoPoseAndObjectsComeMostInliersFirst) {
  std::mt19937 rng(11);
  google::protobuf::RepeatedPtrField<v1::FeatureMatch> matches;
  AddMatches(1, Pose(10, {0, 0, 1}, {0, 0, 1}), 12, 3, &rng, &matches);
  AddMatches(2, Pose(-20, {0, 1, 0}, {0.2, 0, 1.2}), 25, 5, &rng, &matches);
  AddMatches(4, Pose(0, {0, 0, 1}, {0, 0, 1}), 5, 20, &rng, &matches);  // 5 < min_inliers
  const std::vector<SingleViewPose> poses = EstimateSingleViewPoses(matches, kK, {});
  ASSERT_EQ(poses.size(), 2u);
  EXPECT_EQ(poses[0].obj_id, 2);
  EXPECT_EQ(poses[1].obj_id, 1);
  SingleViewOptions strict;
  strict.min_inliers = 20;
  const std::vector<SingleViewPose> only = EstimateSingleViewPoses(matches, kK, strict);
  ASSERT_EQ(only.size(), 1u);
  EXPECT_EQ(only[0].obj_id, 2);
}

TEST(SingleViewTest, ASceneKeepsEachObjectsBestViewInTheWorldFrame) {
  const Eigen::Isometry3d T_wm = Pose(90, {0, 0, 1}, {1, 2, 0.7});
  const Eigen::Isometry3d camera_a = Pose(30, {0, 1, 0}, {0.5, 1.5, 1.2});
  const Eigen::Isometry3d camera_b = Pose(-20, {1, 0, 0}, {1.2, 2.5, 1.0});
  SingleViewPose seen_a{.obj_id = 5, .T_cm = camera_a.inverse() * T_wm, .inliers = 10};
  SingleViewPose seen_b{
      .obj_id = 5,
      .T_cm = camera_b.inverse() * Pose(5, {0, 0, 1}, Eigen::Vector3d::Zero()) * T_wm,
      .inliers = 9};
  SingleViewScene scene;
  scene.Add({seen_b}, camera_b);
  scene.Add({seen_a}, camera_a);  // more inliers: replaces the worse view
  const std::vector<v1::Instance> instances = scene.Instances();
  ASSERT_EQ(instances.size(), 1u);
  EXPECT_EQ(instances[0].obj_id(), 5);
  EXPECT_EQ(instances[0].score(), 10);
  const v1::Vec3& t = instances[0].pose().translation();
  EXPECT_NEAR(t.x(), 1, 1e-9);
  EXPECT_NEAR(t.y(), 2, 1e-9);
  EXPECT_NEAR(t.z(), 0.7, 1e-9);
}

}  // namespace
}  // namespace skimap::client
