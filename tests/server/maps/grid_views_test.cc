// GridViews (server/core/maps/grid_views.h): which view decides a voxel, and what it says.
// Views are built from hand-made depth images of a camera at the origin looking along +z
// (the world frame is the camera's for the identity pose).
#include "server/core/maps/grid_views.h"

#include <gtest/gtest.h>

#include <cmath>

namespace skimap::server {
namespace {

using Verdict = GridViews::Verdict;

// A 64 x 48 frame (32 x 24 kept) whose depth is `metres` everywhere, seen from `position`
// looking along +z.
perception::RgbdFrame Wall(double metres, const Eigen::Vector3d& position = {0, 0, 0}) {
  perception::RgbdFrame f;
  f.camera = {.fx = 60, .fy = 60, .cx = 31.5, .cy = 23.5, .width = 64, .height = 48};
  f.pose.translation = position;
  f.depth.width = 64;
  f.depth.height = 48;
  f.depth.pixels.assign(64 * 48, uint16_t(std::lround(metres * 1000)));
  f.depth_scale = 0.001;
  return f;
}

TEST(GridViewsTest, AVoxelInFrontOfTheMeasuredSurfaceIsSeenThroughOneOnItIsSeen) {
  GridViews views;
  views.Offer(GridViews::MakeView(1, Wall(3.0)));
  const float edge = 0.1f;
  EXPECT_EQ(views.Decide({0, 0, 2.0f}, edge), Verdict::kSeenThrough);
  EXPECT_EQ(views.Decide({0.3f, -0.2f, 2.8f}, edge), Verdict::kSeenThrough);
  // The wall inside the voxel, give or take 3 sigma(3 m) = 0.042 m: on it.
  EXPECT_EQ(views.Decide({0, 0, 2.96f}, edge), Verdict::kSeen);
  EXPECT_EQ(views.Decide({0, 0, 2.9f}, edge), Verdict::kSeenThrough);
  EXPECT_EQ(views.Decide({0, 0, 3.05f}, edge), Verdict::kSeen);
  // Behind the wall (occluded), outside the image, nearer than the sensor's range: no view
  // decides.
  EXPECT_EQ(views.Decide({0, 0, 3.5f}, edge), Verdict::kUndecided);
  EXPECT_EQ(views.Decide({5, 0, 2.0f}, edge), Verdict::kUndecided);
  EXPECT_EQ(views.Decide({0, 0, -1.0f}, edge), Verdict::kUndecided);
  EXPECT_EQ(views.Decide({0, 0, 0.05f}, edge), Verdict::kUndecided);
}

TEST(GridViewsTest, OneUnmeasuredOrNearPixelOfTheFootprintLeavesTheViewUndecided) {
  // The kept rays through a 20 cm voxel at (0, 0, 2) are those of half pixels 15-17 x
  // 11-13 (fx / 2 = 30); through a 5 cm one only (16, 12)'s.
  const Eigen::Vector3f p(0, 0, 2.0f);
  perception::RgbdFrame hole = Wall(3.0);
  hole.depth.pixels[size_t(2 * 11) * 64 + size_t(2 * 17)] = 0;  // half pixel (17, 11)
  GridViews with_hole;
  with_hole.Offer(GridViews::MakeView(1, hole));
  EXPECT_EQ(with_hole.Decide(p, 0.2f), Verdict::kUndecided);
  EXPECT_EQ(with_hole.Decide(p, 0.05f), Verdict::kSeenThrough) << "outside its footprint";
  // A thin thing in front of the voxel on one of its rays: that ray cannot tell.
  perception::RgbdFrame leg = Wall(3.0);
  leg.depth.pixels[size_t(2 * 13) * 64 + size_t(2 * 15)] = 1000;  // half pixel (15, 13), 1 m
  GridViews with_leg;
  with_leg.Offer(GridViews::MakeView(1, leg));
  EXPECT_EQ(with_leg.Decide(p, 0.2f), Verdict::kUndecided);
  // ... and at the voxel's own depth: seen.
  perception::RgbdFrame on = Wall(3.0);
  on.depth.pixels[size_t(2 * 13) * 64 + size_t(2 * 15)] = 2050;
  GridViews with_on;
  with_on.Offer(GridViews::MakeView(1, on));
  EXPECT_EQ(with_on.Decide(p, 0.2f), Verdict::kSeen);
  // The half-resolution pixel kept is the even one: an odd full pixel changes nothing.
  perception::RgbdFrame odd = Wall(3.0);
  odd.depth.pixels[size_t(2 * 12 + 1) * 64 + size_t(2 * 16 + 1)] = 0;
  GridViews with_odd;
  with_odd.Offer(GridViews::MakeView(1, odd));
  EXPECT_EQ(with_odd.Decide(p, 0.2f), Verdict::kSeenThrough);
}

TEST(GridViewsTest, TheNewestViewThatDecidesWins) {
  GridViews views;
  views.Offer(GridViews::MakeView(1, Wall(2.0)));               // sees a surface at 2 m
  views.Offer(GridViews::MakeView(2, Wall(4.0, {1.0, 0, 0})));  // later, from 1 m aside
  EXPECT_EQ(views.size(), 2u);
  EXPECT_EQ(views.Decide({0, 0, 2.0f}, 0.05f), Verdict::kSeenThrough);
  // The newest view is occluded at 4.5 m: the older one decides (behind its 2 m: no).
  GridViews occluded;
  occluded.Offer(GridViews::MakeView(1, Wall(6.0)));
  occluded.Offer(GridViews::MakeView(2, Wall(4.0, {0.5, 0, 0})));
  EXPECT_EQ(occluded.Decide({0, 0, 4.5f}, 0.2f), Verdict::kSeenThrough);
  // And the reverse order: the thing came back.
  GridViews back;
  back.Offer(GridViews::MakeView(1, Wall(4.0, {1.0, 0, 0})));
  back.Offer(GridViews::MakeView(2, Wall(2.0)));
  EXPECT_EQ(back.Decide({0, 0, 2.0f}, 0.05f), Verdict::kSeen);
}

TEST(GridViewsTest, AFrameReplacesTheViewFromItsVantagePointAndTheOldestGoesAtCapacity) {
  GridViews views(GridViews::Options{.capacity = 2, .min_distance = 0.3, .min_angle_deg = 20});
  views.Offer(GridViews::MakeView(1, Wall(2.0)));
  views.Offer(GridViews::MakeView(2, Wall(4.0, {0.1, 0, 0})));  // 10 cm away: replaces 1
  EXPECT_EQ(views.size(), 1u);
  EXPECT_EQ(views.Decide({0, 0, 2.0f}, 0.05f), Verdict::kSeenThrough);
  views.Offer(GridViews::MakeView(3, Wall(4.0, {1.0, 0, 0})));
  views.Offer(GridViews::MakeView(4, Wall(2.0, {2.0, 0, 0})));  // capacity 2: view 2 goes
  EXPECT_EQ(views.size(), 2u);
  // (-0.5, 0, 2) is in view 2's image only (the others' images begin right of x = 0).
  EXPECT_EQ(views.Decide({-0.5f, 0, 2.0f}, 0.05f), Verdict::kUndecided);
  GridViews none(GridViews::Options{.capacity = 0});
  none.Offer(GridViews::MakeView(1, Wall(2.0)));
  EXPECT_EQ(none.size(), 0u);
}

TEST(GridViewsTest, MoveTakesAViewToItsFramesNewPose) {
  GridViews views;
  views.Offer(GridViews::MakeView(7, Wall(4.0)));
  EXPECT_EQ(views.Decide({0, 0, 2.0f}, 0.05f), Verdict::kSeenThrough);
  Eigen::Isometry3d moved = Eigen::Isometry3d::Identity();
  moved.translation() = Eigen::Vector3d(10, 0, 0);
  views.Move(7, moved);
  EXPECT_EQ(views.Decide({0, 0, 2.0f}, 0.05f), Verdict::kUndecided);
  EXPECT_EQ(views.Decide({10, 0, 2.0f}, 0.05f), Verdict::kSeenThrough);
  views.Move(8, Eigen::Isometry3d::Identity());  // not kept: ignored
  EXPECT_EQ(views.Decide({10, 0, 2.0f}, 0.05f), Verdict::kSeenThrough);
}

}  // namespace
}  // namespace skimap::server
