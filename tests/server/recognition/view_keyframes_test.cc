// ViewKeyframes: which recognised frames a map keeps as vantage points, their half
// resolution depth, and their poses following UpdatePoses.
#include "server/core/recognition/view_keyframes.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace skimap::server {
namespace {

constexpr double kDeg = std::numbers::pi / 180;

class ViewKeyframesTest : public ::testing::Test {
 protected:
  ViewKeyframesTest() {
    camera_ = {.fx = 100, .fy = 90, .cx = 40, .cy = 30, .width = 80, .height = 60};
    depth_.width = 80;
    depth_.height = 60;
    depth_.pixels.resize(80 * 60);
    for (int y = 0; y < 60; ++y) {
      for (int x = 0; x < 80; ++x)
        depth_.pixels[y * 80 + x] = static_cast<uint16_t>(1000 + y * 80 + x);
    }
  }

  static Eigen::Isometry3d Pose(const Eigen::Vector3d& t, double yaw_deg) {
    Eigen::Isometry3d p = Eigen::Isometry3d::Identity();
    p.linear() = Eigen::AngleAxisd(yaw_deg * kDeg, Eigen::Vector3d::UnitY()).toRotationMatrix();
    p.translation() = t;
    return p;
  }

  bool Offer(ViewKeyframes& k, uint64_t sequence, const Eigen::Isometry3d& pose) {
    return k.Offer(sequence, depth_, 0.001, camera_, pose);
  }

  perception::PinholeCamera camera_;
  perception::DepthImage depth_;
};

TEST_F(ViewKeyframesTest, KeepsAFrameOnlyFromANewVantagePoint) {
  ViewKeyframes k({.min_distance = 0.15, .min_angle_deg = 15});
  EXPECT_TRUE(Offer(k, 1, Pose({0, 0, 0}, 0)));
  EXPECT_FALSE(Offer(k, 2, Pose({0, 0, 0}, 0)));        // the same place
  EXPECT_FALSE(Offer(k, 3, Pose({0.1, 0, 0}, 10)));     // near in both
  EXPECT_TRUE(Offer(k, 4, Pose({0.2, 0, 0}, 0)));       // moved
  EXPECT_TRUE(Offer(k, 5, Pose({0, 0, 0}, 20)));        // turned
  EXPECT_FALSE(Offer(k, 6, Pose({0.19, 0, 0.05}, 5)));  // near the second
  EXPECT_EQ(k.views().size(), 3u);
}

TEST_F(ViewKeyframesTest, TheOldestGoesWhenFull) {
  ViewKeyframes k({.capacity = 2, .min_distance = 0.15, .min_angle_deg = 15});
  for (int i = 0; i < 3; ++i) EXPECT_TRUE(Offer(k, i + 1, Pose({0.5 * i, 0, 0}, 0)));
  ASSERT_EQ(k.views().size(), 2u);
  EXPECT_NEAR(k.views()[0].camera_from_world.inverse().translation().x(), 0.5, 1e-6);
  EXPECT_NEAR(k.views()[1].camera_from_world.inverse().translation().x(), 1.0, 1e-6);
  // The first frame's place is free again.
  EXPECT_TRUE(Offer(k, 4, Pose({0, 0, 0}, 0)));
}

TEST_F(ViewKeyframesTest, KeepsDepthAtHalfResolutionWithMatchingIntrinsics) {
  ViewKeyframes k({.min_depth = 0.2});
  ASSERT_TRUE(Offer(k, 1, Pose({0, 0, 0}, 0)));
  const ViewFrame& v = k.views()[0];
  ASSERT_EQ(v.depth->width, 40);
  ASSERT_EQ(v.depth->height, 30);
  EXPECT_EQ(v.camera.width, 40);
  EXPECT_EQ(v.camera.height, 30);
  EXPECT_EQ(v.min_depth, 0.2);
  EXPECT_EQ(v.depth_scale, 0.001);
  // Half pixel (x, y) is full pixel (2x, 2y), and a point projects onto both.
  for (const auto& [x, y] : {std::pair{0, 0}, {7, 3}, {39, 29}}) {
    EXPECT_EQ(v.depth->pixels[y * 40 + x], depth_.pixels[(2 * y) * 80 + 2 * x]);
    const Eigen::Vector3d p((2 * x - camera_.cx) / camera_.fx * 2,
                            (2 * y - camera_.cy) / camera_.fy * 2, 2);
    EXPECT_NEAR(v.camera.fx * p.x() / p.z() + v.camera.cx, x, 1e-9);
    EXPECT_NEAR(v.camera.fy * p.y() / p.z() + v.camera.cy, y, 1e-9);
  }
}

TEST_F(ViewKeyframesTest, AKeptFrameFollowsItsPoseUpdate) {
  ViewKeyframes k({});
  ASSERT_TRUE(Offer(k, 7, Pose({0, 0, 0}, 0)));
  k.Move(8, Pose({5, 0, 0}, 0));  // not kept: ignored
  EXPECT_NEAR(k.views()[0].camera_from_world.translation().norm(), 0, 1e-6);
  k.Move(7, Pose({1, 2, 3}, 30));
  const Eigen::Isometry3f world_from_camera = k.views()[0].camera_from_world.inverse();
  EXPECT_TRUE(world_from_camera.isApprox(Pose({1, 2, 3}, 30).cast<float>(), 1e-5f));
  // A frame near the new place is no longer new; one at the old place is.
  EXPECT_FALSE(Offer(k, 9, Pose({1, 2, 3}, 30)));
  EXPECT_TRUE(Offer(k, 10, Pose({0, 0, 0}, 0)));
}

// The smallest frame a client may send (1 x 1 pixels) leaves an empty half image: kept, and
// nothing is read from it (ASan runs this).
TEST_F(ViewKeyframesTest, AOnePixelFrameLeavesAnEmptyViewThatCountsNothing) {
  ViewKeyframes k({});
  const perception::DepthImage one{.width = 1, .height = 1, .pixels = {1000}};
  ASSERT_TRUE(k.Offer(1, one, 0.001,
                      {.fx = 1, .fy = 1, .cx = 0.5, .cy = 0.5, .width = 1, .height = 1},
                      Pose({0, 0, 0}, 0)));
  const ViewFrame& v = k.views()[0];
  EXPECT_EQ(v.depth->width, 0);
  EXPECT_EQ(v.depth->height, 0);
  EXPECT_TRUE(v.depth->pixels.empty());
  recognition::ObjectShape shape;
  shape.surface = {{.p = Eigen::Vector3f(0, 0, 0)}, {.p = Eigen::Vector3f(0.01f, 0, 0)}};
  shape.radius = 0.01f;
  uint32_t agree = 0, conflict = 0;
  Eigen::Isometry3f pose = Eigen::Isometry3f::Identity();
  pose.translation() = Eigen::Vector3f(0, 0, 1);
  CountView(shape, pose, v, &agree, &conflict);
  EXPECT_EQ(agree + conflict, 0u);
}

}  // namespace
}  // namespace skimap::server
