// client/cli/pose_score.h: errors under symmetries, one-to-one matching, BOP's MSSD recall.
#include "client/cli/pose_score.h"

#include <gtest/gtest.h>

#include <cmath>

namespace skimap::client {
namespace {

Eigen::Isometry3d Pose(double angle_z_deg, Eigen::Vector3d t) {
  Eigen::Isometry3d p = Eigen::Isometry3d::Identity();
  p.linear() =
      Eigen::AngleAxisd(angle_z_deg * M_PI / 180, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  p.translation() = t;
  return p;
}

v1::Instance Instance(uint64_t id, int obj_id, const Eigen::Isometry3d& pose) {
  v1::Instance i;
  i.set_id(id);
  i.set_obj_id(obj_id);
  const Eigen::Quaterniond q(pose.linear());
  i.mutable_pose()->mutable_rotation()->set_w(q.w());
  i.mutable_pose()->mutable_rotation()->set_x(q.x());
  i.mutable_pose()->mutable_rotation()->set_y(q.y());
  i.mutable_pose()->mutable_rotation()->set_z(q.z());
  i.mutable_pose()->mutable_translation()->set_x(pose.translation().x());
  i.mutable_pose()->mutable_translation()->set_y(pose.translation().y());
  i.mutable_pose()->mutable_translation()->set_z(pose.translation().z());
  return i;
}

TEST(PoseScoreTest, ASymmetricEquivalentCountsAsTheTruth) {
  const Eigen::Isometry3d truth = Pose(30, {1, 2, 0.5});
  const Eigen::Isometry3d turned = truth * Pose(180, {0, 0, 0});  // half a turn about z
  PoseError plain = ErrorUnderSymmetries(turned, truth, {});
  EXPECT_NEAR(plain.rotation_deg, 180, 1e-6);
  PoseError symmetric = ErrorUnderSymmetries(turned, truth, {Pose(180, {0, 0, 0})});
  EXPECT_NEAR(symmetric.rotation_deg, 0, 1e-6);
  EXPECT_NEAR(symmetric.translation, 0, 1e-12);
}

TEST(PoseScoreTest, MatchesOneToOneWithinTheTolerance) {
  std::map<int, dataset::ModelInfo> models;
  models[2].symmetries = {Pose(180, {0, 0, 0})};
  const std::vector<TruthObject> truths = {{1, Pose(0, {0, 0, 0})},
                                           {1, Pose(0, {1, 0, 0})},
                                           {2, Pose(90, {2, 0, 0})},
                                           {3, Pose(0, {3, 0, 0})}};
  const std::vector<v1::Instance> instances = {
      Instance(10, 1, Pose(5, {0.01, 0, 0})),    // truth 0: 10 mm, 5 degrees
      Instance(11, 1, Pose(0, {0.005, 0, 0})),   // also near truth 0, closer: takes it
      Instance(12, 1, Pose(0, {1.05, 0, 0})),    // 5 cm from truth 1: too far
      Instance(13, 2, Pose(270, {2.02, 0, 0})),  // truth 2 under its symmetry, 20 mm
      Instance(14, 3, Pose(15, {3, 0, 0})),      // truth 3 turned 15 degrees: too much
      Instance(15, 4, Pose(0, {0, 0, 0}))};      // an object not in the scene
  const SceneScore s = ScoreScene(truths, instances, models, ScoreOptions{});
  EXPECT_EQ(s.truths, 4);
  EXPECT_EQ(s.instances, 6);
  EXPECT_EQ(s.true_positives, 2);
  EXPECT_EQ(s.match, (std::vector<int>{1, -1, 3, -1}));
  EXPECT_NEAR(s.error[2].translation, 0.02, 1e-9);
  EXPECT_NEAR(s.error[2].rotation_deg, 0, 1e-6);
  // A looser tolerance takes the far and the turned ones too.
  const SceneScore loose = ScoreScene(truths, instances, models, {0.1, 20});
  EXPECT_EQ(loose.true_positives, 4);
}

// The 8 corners of a box 0.2 x 0.1 x 0.05 m centred on the origin.
std::vector<Eigen::Vector3d> BoxCorners() {
  std::vector<Eigen::Vector3d> corners;
  for (double x : {-0.1, 0.1}) {
    for (double y : {-0.05, 0.05}) {
      for (double z : {-0.025, 0.025}) corners.emplace_back(x, y, z);
    }
  }
  return corners;
}

TEST(PoseScoreTest, MssdIsTheLargestPointDistanceUnderTheBestSymmetry) {
  const std::vector<Eigen::Vector3d> box = BoxCorners();
  const Eigen::Isometry3d truth = Pose(30, {1, 2, 0.5});
  // A pure translation moves every point by it.
  EXPECT_NEAR(MssdError(Pose(30, {1.01, 2, 0.5}), truth, box, {}), 0.01, 1e-12);
  // A turn about z by a small angle a moves the farthest corner (radius r = |(0.1, 0.05)|)
  // by 2 r sin(a / 2).
  const double r = std::hypot(0.1, 0.05);
  EXPECT_NEAR(MssdError(truth * Pose(4, {0, 0, 0}), truth, box, {}),
              2 * r * std::sin(2 * M_PI / 180), 1e-12);
  // Half a turn: the far corners swap, unless the box's symmetry says it looks the same.
  const Eigen::Isometry3d turned = truth * Pose(180, {0, 0, 0});
  EXPECT_NEAR(MssdError(turned, truth, box, {}), 2 * r, 1e-12);
  EXPECT_NEAR(MssdError(turned, truth, box, {Pose(180, {0, 0, 0})}), 0, 1e-12);
}

TEST(PoseScoreTest, MssdRecallAveragesTheTenThresholds) {
  std::map<int, dataset::ModelInfo> models;
  models[1].diameter = 0.2;  // thresholds 10, 20, ..., 100 mm
  models[2].diameter = 0.2;
  const std::map<int, std::vector<Eigen::Vector3d>> points = {{1, BoxCorners()}, {2, BoxCorners()}};
  const std::vector<TruthObject> truths = {{1, Pose(0, {0, 0, 0})},
                                           {1, Pose(0, {1, 0, 0})},
                                           {2, Pose(0, {2, 0, 0})},
                                           {3, Pose(0, {3, 0, 0})}};  // no model: never matched
  std::vector<v1::Instance> instances = {
      Instance(10, 1, Pose(0, {0.015, 0, 0})),  // truth 0 at 15 mm: thresholds 20..100
      Instance(11, 1, Pose(0, {0.035, 0, 0})),  // also nearest truth 0, lower score
      Instance(12, 2, Pose(0, {2.055, 0, 0})),  // truth 2 at 55 mm: thresholds 60..100
      Instance(13, 3, Pose(0, {3, 0, 0}))};
  instances[0].set_score(50);
  instances[1].set_score(10);
  instances[2].set_score(30);
  MssdRecall recall;
  AddMssdScene(truths, instances, models, points, &recall);
  EXPECT_EQ(recall.truths, 4);
  // Instance 11 never takes truth 1 (1 m away), nor truth 0 once 10 has it.
  EXPECT_EQ(std::vector<int>(recall.matched, recall.matched + MssdRecall::kThresholds),
            (std::vector<int>{0, 1, 1, 1, 1, 2, 2, 2, 2, 2}));
  EXPECT_NEAR(recall.Average(), (4 * 1 + 5 * 2) / 4.0 / 10, 1e-12);
  // The higher score matches first: with the scores swapped, 11 (35 mm) takes truth 0 at
  // thresholds 40..100 and 10 gets it at 20 and 30; a truth still counts once.
  instances[0].set_score(10);
  instances[1].set_score(50);
  MssdRecall swapped;
  AddMssdScene(truths, instances, models, points, &swapped);
  EXPECT_EQ(std::vector<int>(swapped.matched, swapped.matched + MssdRecall::kThresholds),
            (std::vector<int>{0, 1, 1, 1, 1, 2, 2, 2, 2, 2}));
}

}  // namespace
}  // namespace skimap::client
