// Orientation clustering of hypotheses into instance estimates
// (perception/recognition/instance_estimator.h).
#include "perception/recognition/instance_estimator.h"

#include <gtest/gtest.h>

#include <random>
#include <vector>

namespace skimap::recognition {
namespace {

constexpr float kDeg = float(M_PI) / 180;

Eigen::Quaternionf Rot(float deg, const Eigen::Vector3f& axis) {
  return Eigen::Quaternionf(Eigen::AngleAxisf(deg * kDeg, axis.normalized()));
}

TEST(InstanceEstimatorTest, OrientationClusteringPicksTheInlierCluster) {
  std::mt19937_64 rng(3);
  std::normal_distribution<float> small(0, 1.0f);  // degrees / millimetres
  const Eigen::Quaternionf truth = Rot(40, {1, 2, 3});
  const Eigen::Vector3f at(1, 2, 0.8f);
  std::vector<HypothesisSample> h;
  // 20 inliers within ~2 degrees and 3 mm; 12 outliers at the same place, rotations spread
  // over all of SO(3) (as wrong triples give); one of them in a tight group of three.
  for (int i = 0; i < 20; ++i) {
    const Eigen::Quaternionf q =
        truth * Rot(std::abs(small(rng)) * 2, {small(rng), small(rng), small(rng)});
    h.push_back(
        {at + 0.003f * Eigen::Vector3f(small(rng), small(rng), small(rng)), q, 10, uint64_t(i)});
  }
  std::uniform_real_distribution<float> any(-1, 1);
  for (int i = 0; i < 12; ++i) {
    const Eigen::Quaternionf q =
        Eigen::Quaternionf(any(rng), any(rng), any(rng), any(rng)).normalized();
    h.push_back({at + Eigen::Vector3f(0.01f, 0, 0), q, 14, uint64_t(100 + i)});
  }
  for (int i = 0; i < 3; ++i) {
    h.push_back({at, Rot(170, {0, 0, 1}) * Rot(float(i), {1, 0, 0}), 15, uint64_t(200 + i)});
  }
  const std::vector<InstanceEstimate> e = EstimateInstances(h, {});
  ASSERT_FALSE(e.empty());
  EXPECT_LT(RotationAngle(e.front().q, truth), 2 * kDeg);
  EXPECT_LT((e.front().t - at).norm(), 0.003f);
  EXPECT_GE(e.front().support, 18);
  EXPECT_LE(e.front().support, 22);
  EXPECT_EQ(e.front().first_frame, 0u);
  EXPECT_LT(e.front().spread_r, 5 * kDeg);
}

TEST(InstanceEstimatorTest, SeparatePlacesGiveSeparateEstimates) {
  std::vector<HypothesisSample> h;
  for (int i = 0; i < 4; ++i) {
    h.push_back({{0, 0, 0}, Eigen::Quaternionf::Identity(), 5, uint64_t(i)});
    h.push_back({{1, 0, 0}, Rot(90, {0, 0, 1}), 3, uint64_t(i)});
  }
  const std::vector<InstanceEstimate> e = EstimateInstances(h, {});
  ASSERT_EQ(e.size(), 2u);
  EXPECT_LT(e[0].t.norm(), 1e-6f);
  EXPECT_LT((e[1].t - Eigen::Vector3f(1, 0, 0)).norm(), 1e-6f);
  EXPECT_LT(RotationAngle(e[1].q, Rot(90, {0, 0, 1})), 1e-3f);
  EXPECT_EQ(e[0].frames, 4);
}

TEST(InstanceEstimatorTest, TooLittleSupportOrASingleFrameGivesNothing) {
  std::vector<HypothesisSample> one_frame(5, {{0, 0, 0}, Eigen::Quaternionf::Identity(), 5, 9});
  EXPECT_TRUE(EstimateInstances(one_frame, {}).empty());
  std::vector<HypothesisSample> two = {{{0, 0, 0}, Eigen::Quaternionf::Identity(), 5, 1},
                                       {{0, 0, 0}, Eigen::Quaternionf::Identity(), 5, 2}};
  EXPECT_TRUE(EstimateInstances(two, {}).empty());
}

}  // namespace
}  // namespace skimap::recognition
