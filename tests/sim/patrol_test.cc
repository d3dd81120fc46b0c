// The robot preset's pieces: the patrol trajectory (a head camera at the robot's height,
// driving at its speed, looking down at supports) and objects placed on the floor.
#include <gtest/gtest.h>

#include <cmath>

#include "sim/objects.h"
#include "sim/scene.h"
#include "sim/trajectory.h"

namespace skimap::sim {
namespace {

// A room like the robot preset's "apartment", its objects and distractors on plain boxes.
SceneLayout Room(int floor_objects, uint64_t seed) {
  std::vector<ObjectModel> objects;
  for (int i = 1; i <= 8; ++i) {
    objects.push_back({i, "box", MakeBox({0.1f, 0.08f, 0.15f}, FlatTexture(200, 40, 40), 1)});
  }
  const std::vector<Mesh> distractors = {MakeBox({0.2f, 0.2f, 0.2f}, FlatTexture(9, 9, 9), 1)};
  std::mt19937_64 rng(seed);
  return MakeRoom({"apartment", 7.0f, 6.0f, 2.6f, 2, 1, 2, 8, 3, floor_objects}, objects,
                  distractors, rng);
}

TEST(PatrolTest, CameraKeepsItsHeightSpeedAndLooksDown) {
  const SceneLayout room = Room(2, 1);
  TrajectoryOptions o;
  o.kind = TrajectoryKind::kPatrol;
  o.frames = 600;
  o.speed = 0.4;
  o.height = 1.3f;
  const std::vector<Eigen::Isometry3f> poses = MakeTrajectory(room, o);
  ASSERT_EQ(poses.size(), 600u);
  double path = 0;
  for (size_t i = 0; i < poses.size(); ++i) {
    const Eigen::Vector3f p = poses[i].translation();
    EXPECT_NEAR(p.z(), 1.3f, 0.011f) << "frame " << i;  // the head bobs 1 cm
    // The optical axis (camera z) points 10-35 degrees below the horizon.
    const float down = std::asin(-poses[i].linear().col(2).z()) * 180 / 3.14159265f;
    EXPECT_GE(down, 9.9f) << "frame " << i;
    EXPECT_LE(down, 35.1f) << "frame " << i;
    if (i > 0) path += (p - poses[i - 1].translation()).head<2>().norm();
  }
  EXPECT_NEAR(path / (599 / 30.0), 0.4, 0.02);  // m/s along the loop
}

TEST(PatrolTest, TheHeadTurnsTowardsTheTables) {
  const SceneLayout room = Room(0, 2);
  TrajectoryOptions o;
  o.kind = TrajectoryKind::kPatrol;
  o.frames = 900;
  const std::vector<Eigen::Isometry3f> poses = MakeTrajectory(room, o);
  // Most frames see a table centre within 40 degrees of the optical axis, 1.2-4 m away.
  int seeing = 0;
  for (const Eigen::Isometry3f& T : poses) {
    for (const Support& s : room.supports) {
      if (s.name.rfind("table", 0) != 0) continue;
      const Eigen::Vector2f c2 = (s.min + s.max) / 2;
      const Eigen::Vector3f to = Eigen::Vector3f(c2.x(), c2.y(), s.z) - T.translation();
      const float angle = std::acos(to.normalized().dot(T.linear().col(2))) * 180 / 3.14159265f;
      if (angle < 40 && to.norm() < 4.0f) {
        ++seeing;
        break;
      }
    }
  }
  EXPECT_GT(seeing, 0.6 * poses.size());
}

TEST(PatrolTest, FloorObjectsStandOnTheFloorBesideTheTables) {
  const SceneLayout room = Room(2, 3);
  int on_floor = 0;
  for (const Placement& p : room.objects) {
    if (p.support.rfind("floor", 0) != 0) continue;
    ++on_floor;
    EXPECT_NEAR(p.T_wm.translation().z(), 0.04f, 0.04f);  // half the box's height or less
    for (const Support& s : room.supports) {              // not under a table
      if (s.name.rfind("table", 0) != 0) continue;
      const Eigen::Vector2f xy = p.T_wm.translation().head<2>();
      EXPECT_FALSE(xy.x() > s.min.x() && xy.x() < s.max.x() && xy.y() > s.min.y() &&
                   xy.y() < s.max.y());
    }
  }
  EXPECT_EQ(on_floor, 2);
  EXPECT_EQ(room.objects.size(), 8u);
}

}  // namespace
}  // namespace skimap::sim
