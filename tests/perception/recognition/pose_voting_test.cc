// 3-point rigid fits and 3-point RANSAC + Hough voting (perception/recognition/pose_voting.h)
// on synthetic label matches with a known pose.
#include "perception/recognition/pose_voting.h"

#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "perception/recognition/instance_estimator.h"

namespace skimap::recognition {
namespace {

Eigen::Isometry3f KnownPose() {
  Eigen::Isometry3f t = Eigen::Isometry3f::Identity();
  t.linear() =
      (Eigen::AngleAxisf(0.7f, Eigen::Vector3f(0.3f, -0.5f, 0.8f).normalized())).toRotationMatrix();
  t.translation() = Eigen::Vector3f(1.5f, -0.4f, 0.75f);
  return t;
}

float AngleBetween(const Eigen::Isometry3f& a, const Eigen::Isometry3f& b) {
  return RotationAngle(Eigen::Quaternionf(a.linear()), Eigen::Quaternionf(b.linear()));
}

// Points on the surface of a 16 x 10 x 24 cm box (model frame, origin at its centre).
std::vector<Eigen::Vector3f> BoxSurface(std::mt19937_64& rng, int n) {
  std::uniform_real_distribution<float> u(-1, 1);
  std::uniform_int_distribution<int> face(0, 5);
  const Eigen::Vector3f half(0.08f, 0.05f, 0.12f);
  std::vector<Eigen::Vector3f> out;
  for (int i = 0; i < n; ++i) {
    Eigen::Vector3f p(u(rng), u(rng), u(rng));
    const int f = face(rng);
    p[f / 2] = f % 2 ? 1.0f : -1.0f;
    out.push_back(p.cwiseProduct(half));
  }
  return out;
}

ObjectShape BoxShape() {
  ObjectShape s;
  s.base = {0, 0, -0.12f};
  s.radius = Eigen::Vector3f(0.08f, 0.05f, 0.12f).norm();
  s.wanted = true;
  return s;
}

TEST(FitRigidTest, ThreeExactMatchesRecoverThePose) {
  const Eigen::Isometry3f truth = KnownPose();
  const std::vector<Eigen::Vector3f> model = {{0, 0, 0}, {0.1f, 0, 0}, {0, 0.07f, 0.03f}};
  std::vector<LabelMatch> matches;
  for (const Eigen::Vector3f& v : model) matches.push_back({truth * v, v, 1});
  const Eigen::Isometry3f fit = FitRigid(matches);
  EXPECT_LT((fit.translation() - truth.translation()).norm(), 1e-5f);
  EXPECT_LT(AngleBetween(fit, truth), 1e-4f);
}

TEST(FitRigidTest, WeightedFitIgnoresZeroWeightOutliers) {
  std::mt19937_64 rng(9);
  const Eigen::Isometry3f truth = KnownPose();
  std::vector<LabelMatch> matches;
  std::vector<float> weights;
  for (const Eigen::Vector3f& v : BoxSurface(rng, 30)) {
    matches.push_back({truth * v, v, 1});
    weights.push_back(1);
    matches.push_back({truth * v + Eigen::Vector3f(0.3f, -0.2f, 0.1f), v, 1});  // outlier
    weights.push_back(0);
  }
  const Eigen::Isometry3f fit = FitRigidWeighted(matches, weights);
  EXPECT_LT((fit.translation() - truth.translation()).norm(), 1e-4f);
  EXPECT_LT(AngleBetween(fit, truth), 1e-3f);
}

TEST(PoseVotingTest, RefinementTightensASmallObjectsRotation) {
  // A 5 cm cube's matches with 3 mm noise; refinement from a pose turned by 15 degrees
  // (within the 2 cm inlier distance for most points) must come back near the truth.
  std::mt19937_64 rng(13);
  std::normal_distribution<float> noise(0, 0.003f);
  std::uniform_real_distribution<float> u(-1, 1);
  const Eigen::Isometry3f truth = KnownPose();
  std::vector<LabelMatch> matches;
  for (int i = 0; i < 80; ++i) {
    Eigen::Vector3f v(u(rng), u(rng), u(rng));
    v[i % 3] = i % 2 ? 1.0f : -1.0f;
    v *= 0.025f;
    matches.push_back({truth * v + Eigen::Vector3f(noise(rng), noise(rng), noise(rng)), v, 1});
  }
  Eigen::Isometry3f start = truth;
  start.linear() = truth.linear() *
                   Eigen::AngleAxisf(15 * float(M_PI) / 180, Eigen::Vector3f(1, 1, 0).normalized())
                       .toRotationMatrix();
  const PoseEstimate refined = RefinePose(matches, start, 0.02f);
  EXPECT_LT(AngleBetween(refined.pose, truth), 3 * float(M_PI) / 180);
  EXPECT_LT((refined.pose.translation() - truth.translation()).norm(), 0.003f);
}

TEST(PoseVotingTest, FindsAKnownPoseAmongHalfOutliers) {
  std::mt19937_64 rng(7);
  const Eigen::Isometry3f truth = KnownPose();
  std::vector<LabelMatch> matches;
  // 120 inliers with 3 mm of noise, 120 outliers: model points paired with random places in
  // the sphere.
  std::normal_distribution<float> noise(0, 0.003f);
  std::uniform_real_distribution<float> inside(-0.4f, 0.4f);
  const Sphere sphere{truth.translation() + Eigen::Vector3f(0.1f, 0.1f, 0), 0.6f};
  for (const Eigen::Vector3f& v : BoxSurface(rng, 120)) {
    matches.push_back({truth * v + Eigen::Vector3f(noise(rng), noise(rng), noise(rng)), v, 1});
  }
  for (const Eigen::Vector3f& v : BoxSurface(rng, 120)) {
    matches.push_back(
        {sphere.centre + Eigen::Vector3f(inside(rng), inside(rng), inside(rng)), v, 1});
  }
  std::shuffle(matches.begin(), matches.end(), rng);
  const std::vector<PoseEstimate> found = VotePoses(matches, BoxShape(), sphere, {}, rng);
  ASSERT_FALSE(found.empty());
  const PoseEstimate& best = found.front();
  EXPECT_LT((best.pose.translation() - truth.translation()).norm(), 0.005f);
  EXPECT_LT(AngleBetween(best.pose, truth), 2 * float(M_PI) / 180);
  EXPECT_GE(best.inliers, 110);  // nearly every inlier, and few of the outliers
  EXPECT_LE(best.inliers, 130);
}

TEST(PoseVotingTest, PureOutliersGiveNoStrongHypothesis) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<float> inside(-0.4f, 0.4f);
  const Sphere sphere{{0, 0, 1}, 0.6f};
  std::vector<LabelMatch> matches;
  for (const Eigen::Vector3f& v : BoxSurface(rng, 200)) {
    matches.push_back(
        {sphere.centre + Eigen::Vector3f(inside(rng), inside(rng), inside(rng)), v, 1});
  }
  VotingOptions options;
  options.min_score = 12;
  EXPECT_TRUE(VotePoses(matches, BoxShape(), sphere, options, rng).empty());
}

TEST(PoseVotingTest, FewerThanThreeMatchesGiveNothing) {
  std::mt19937_64 rng(1);
  std::vector<LabelMatch> two = {{{0, 0, 0}, {0, 0, 0}, 1}, {{0.1f, 0, 0}, {0.1f, 0, 0}, 1}};
  EXPECT_TRUE(VotePoses(two, BoxShape(), {{0, 0, 0}, 0.5f}, {}, rng).empty());
}

}  // namespace
}  // namespace skimap::recognition
