// ReconcileInstances (server/core/recognition/instance_reconciler.h) on a hand-built MapState:
// labels, hypotheses and instances placed exactly, an object database of one small object (no
// training), so each rule of the reconciliation can be checked by itself.
#include "server/core/recognition/instance_reconciler.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <span>
#include <vector>

#include "codec/image_codec.h"
#include "server/core/recognition/instance_proto.h"
#include "tests/perception/objects/small_database.h"

namespace skimap::server {
namespace {

constexpr uint32_t kObjId = 10;  // SmallOrbDatabase's first object

// One object whose 6 descriptor voxels span a 4 cm corner (not collinear), so three label
// matches fix a pose.
std::shared_ptr<const objects::ObjectDatabase> Database() {
  static const auto* db = new std::shared_ptr<const objects::ObjectDatabase>(
      std::make_shared<objects::ObjectDatabase>(objects::SmallOrbDatabase(
          {{{0, 0, 0}, {4, 0, 0}, {0, 4, 0}, {0, 0, 4}, {4, 4, 0}, {4, 0, 4}}})));
  return *db;
}

// The object's labels where the object at `pose` puts them, 5 observations each.
void AddLabelsAt(const recognition::RecognitionModel& model, const Eigen::Isometry3f& pose,
                 MapState* state) {
  Eigen::Vector3f v;
  int object = -1;
  for (uint32_t c = 0; model.ClassPoint(c, &v, &object); ++c) {
    const Eigen::Vector3f w = pose * v;
    VoxelKey key;
    ASSERT_TRUE(state->labels.grid().ToKey(w.x(), w.y(), w.z(), &key));
    state->labels.IntegrateKey(key, MultiLabelVoxel(c, 5));
  }
}

// Four hypotheses of the object at `pose`, from frames 1 to 4.
void AddHypothesesAt(const Eigen::Isometry3f& pose, MapState* state) {
  const Eigen::Quaternionf q(pose.linear());
  const Eigen::Vector3f t = pose.translation();
  for (uint64_t frame : {1, 2, 3, 4}) {
    const Hypothesis h{.t = {t.x(), t.y(), t.z()},
                       .q = {q.w(), q.x(), q.y(), q.z()},
                       .object_id = kObjId,
                       .score = 15,
                       .frame = frame};
    VoxelKey key;
    ASSERT_TRUE(state->hypotheses.grid().ToKey(t.x(), t.y(), t.z(), &key));
    state->hypotheses.IntegrateKey(key, HypothesesVoxel(h));
  }
}

class ReconcilerTest : public ::testing::Test {
 protected:
  ReconcilerTest() : model_(*recognition::RecognitionModel::Create(Database(), {})) {}

  const recognition::ObjectShape& shape() const { return model_.object(0); }

  void AddLabels(const Eigen::Isometry3f& pose) { AddLabelsAt(model_, pose, &state_); }
  void AddHypotheses(const Eigen::Isometry3f& pose) { AddHypothesesAt(pose, &state_); }

  // An existing instance of the object at `t` (identity rotation).
  void PutInstance(uint64_t id, const Eigen::Vector3f& t, float score) {
    Instance i;
    i.id = id;
    i.object_id = kObjId;
    i.t = {t.x(), t.y(), t.z()};
    i.score = score;
    i.support = 4;
    i.frames = 2;
    VoxelKey key;
    ASSERT_TRUE(state_.instances.grid().ToKey(t.x(), t.y(), t.z(), &key));
    state_.instances.IntegrateKey(key, InstancesVoxel(i));
    state_.recognition.instance_keys[id] = key;
    state_.recognition.next_instance_id = std::max(state_.recognition.next_instance_id, id + 1);
  }

  std::vector<Instance> Instances() const {
    std::vector<Instance> out;
    state_.instances.ForEach([&](const VoxelKey&, const InstancesVoxel& v) {
      out.insert(out.end(), v.items().begin(), v.items().end());
    });
    return out;
  }

  int Reconcile(const recognition::Sphere& region) {
    return ReconcileInstances(
        model_,
        {.map_id = "m", .visible = {.min_score = 8, .min_fit = 0, .max_view_conflict = 0.1}},
        {.object_index = 0, .region = region, .frame = 5, .frame_supports = true}, &state_);
  }

  recognition::RecognitionModel model_;
  MapConfig config_;
  MapState state_{config_, nullptr};
};

Eigen::Isometry3f At(const Eigen::Vector3f& t) {
  Eigen::Isometry3f pose = Eigen::Isometry3f::Identity();
  pose.translation() = t;
  return pose;
}

TEST_F(ReconcilerTest, AnEstimateBecomesOneInstanceAtItsPose) {
  const Eigen::Vector3f t(0.3f, 0.1f, 0.2f);
  AddLabels(At(t));
  AddHypotheses(At(t));
  Reconcile({.centre = t, .radius = 0.5f});
  const std::vector<Instance> found = Instances();
  ASSERT_EQ(found.size(), 1u);
  EXPECT_EQ(found[0].id, 1u);
  EXPECT_LT((Eigen::Vector3f(found[0].t[0], found[0].t[1], found[0].t[2]) - t).norm(), 0.005f);
  EXPECT_GE(found[0].score, 30);  // the 6 labels x 5
  EXPECT_EQ(found[0].support, 4u);
  EXPECT_EQ(found[0].frames, 4u);
}

// An instance updated near the edge of the region may move next to an instance of the
// object just beyond the region's reach: they are one (seen on the sk scenes, where two
// instances of the cereal box stayed listed at the same pose).
TEST_F(ReconcilerTest, AnUpdatedInstanceMergesWithOneJustBeyondTheRegion) {
  const float d = std::max(shape().radius, 0.03f);  // the match distance
  const recognition::Sphere region{.centre = Eigen::Vector3f::Zero(), .radius = 0.5f};
  const float reach = region.radius + shape().radius + d;
  const Eigen::Vector3f x = Eigen::Vector3f::UnitX();
  const Eigen::Vector3f estimate = (reach - 0.01f) * x;  // inside the reach
  AddLabels(At(estimate));
  AddHypotheses(At(estimate));
  PutInstance(1, estimate + 0.015f * x, 20);  // beyond the reach, within d of the estimate
  PutInstance(2, estimate - 0.02f * x, 20);   // inside: the estimate updates it
  ASSERT_GT((estimate + 0.015f * x).norm(), reach);
  ASSERT_LT(0.02f, d);

  Reconcile(region);
  const std::vector<Instance> found = Instances();
  ASSERT_EQ(found.size(), 1u);
  EXPECT_EQ(found[0].id, 1u);  // the older id stays
  EXPECT_LT((Eigen::Vector3f(found[0].t[0], found[0].t[1], found[0].t[2]) - estimate).norm(),
            0.005f);
  EXPECT_FALSE(state_.recognition.instance_keys.contains(2));
}

TEST_F(ReconcilerTest, AnInstanceBeyondTheMatchDistanceStaysApart) {
  const float d = std::max(shape().radius, 0.03f);
  const Eigen::Vector3f t(0.2f, 0, 0);
  AddLabels(At(t));
  AddHypotheses(At(t));
  PutInstance(1, t + Eigen::Vector3f(0, 0, d + 0.05f), 20);  // elsewhere, with hypotheses
  AddHypotheses(At(t + Eigen::Vector3f(0, 0, d + 0.05f)));
  Reconcile({.centre = Eigen::Vector3f::Zero(), .radius = 0.5f});
  EXPECT_EQ(Instances().size(), 2u);
}

// The same object with a surface (its 6 voxels), seen by a camera at the world origin
// looking along +z (64 x 48 px, f = 50 px).
class ReconcilerViewTest : public ::testing::Test {
 protected:
  static std::shared_ptr<const objects::ObjectDatabase> SurfaceDatabase() {
    static const auto* db = new std::shared_ptr<const objects::ObjectDatabase>(
        std::make_shared<objects::ObjectDatabase>(objects::SmallOrbDatabase(
            {{{0, 0, 0}, {4, 0, 0}, {0, 4, 0}, {0, 0, 4}, {4, 4, 0}, {4, 0, 4}}}, true)));
    return *db;
  }
  ReconcilerViewTest() : model_(*recognition::RecognitionModel::Create(SurfaceDatabase(), {})) {
    view_.camera = {.fx = 50, .fy = 50, .cx = 32, .cy = 24, .width = 64, .height = 48};
    view_.depth_scale = 0.001;
    depth_.width = 64;
    depth_.height = 48;
    depth_.pixels.assign(64 * 48, 0);
    view_.depth = &depth_;
  }

  // Labels and hypotheses of the object at `pose`.
  void Observe(const Eigen::Isometry3f& pose) {
    AddLabelsAt(model_, pose, &state_);
    AddHypothesesAt(pose, &state_);
  }

  // The depth the camera measures of the object's surface points at `pose` (a pixel keeps
  // its nearest point); every other pixel measures `background` metres (0: nothing).
  void RenderDepth(const Eigen::Isometry3f& pose, double background) {
    std::fill(depth_.pixels.begin(), depth_.pixels.end(),
              static_cast<uint16_t>(std::lround(background * 1000)));
    std::vector<bool> drawn(depth_.pixels.size(), false);
    for (const recognition::SurfacePoint& s : model_.object(0).surface) {
      const Eigen::Vector3f p = pose * s.p;
      const long u = std::lround(50 * p.x() / p.z() + 32), v = std::lround(50 * p.y() / p.z() + 24);
      ASSERT_TRUE(u >= 0 && u < 64 && v >= 0 && v < 48);
      const size_t i = static_cast<size_t>(v) * 64 + u;
      const auto mm = static_cast<uint16_t>(std::lround(p.z() * 1000));
      if (!drawn[i] || mm < depth_.pixels[i]) depth_.pixels[i] = mm;
      drawn[i] = true;
    }
  }

  Instance Only() const {
    std::vector<Instance> out;
    state_.instances.ForEach([&](const VoxelKey&, const InstancesVoxel& v) {
      out.insert(out.end(), v.items().begin(), v.items().end());
    });
    EXPECT_EQ(out.size(), 1u);
    return out.empty() ? Instance{} : out[0];
  }

  // What a recognised frame does: reconcile the object, checking the instances it updates
  // against the map's keyframes (here `view_` alone). The events.
  int Reconcile(const Eigen::Vector3f& centre) {
    return ReconcileInViews(centre, std::span<const ViewFrame>(&view_, 1));
  }
  int ReconcileInViews(const Eigen::Vector3f& centre, std::span<const ViewFrame> views) {
    return ReconcileInstances(
        model_,
        {.map_id = "m", .visible = {.min_score = 8, .min_fit = 0, .max_view_conflict = 0.1}},
        {.object_index = 0,
         .region = {.centre = centre, .radius = 0.5f},
         .frame = 5,
         .frame_supports = true,
         .views = views},
        &state_);
  }

  std::vector<v1::InstanceEvent::Type> EventTypes() const {
    std::vector<v1::InstanceEvent> events;
    EXPECT_TRUE(state_.recognition.log.After(0, 1000, &events).ok());
    std::vector<v1::InstanceEvent::Type> out;
    for (const v1::InstanceEvent& e : events) out.push_back(e.type());
    return out;
  }

  recognition::RecognitionModel model_;
  perception::DepthImage depth_;
  ViewFrame view_;
  MapConfig config_;
  MapState state_{config_, nullptr};
};

TEST_F(ReconcilerViewTest, AnInstanceWhereTheCameraSawItAgreesAndIsListed) {
  ASSERT_EQ(model_.object(0).surface.size(), 6u);
  const Eigen::Isometry3f pose = At({0, 0, 1});
  Observe(pose);
  RenderDepth(pose, 0);
  EXPECT_EQ(Reconcile(pose.translation()), 1);
  EXPECT_EQ(EventTypes(), std::vector<v1::InstanceEvent::Type>{v1::InstanceEvent::CREATED});
  const Instance i = Only();
  EXPECT_GE(i.view_agree, 4u);  // the nearest of points sharing a pixel; the rest hidden
  EXPECT_EQ(i.view_conflict, 0u);
  EXPECT_EQ(ViewConflict(i), 0.0f);
  EXPECT_EQ(ToProto(i, &model_, "m").view_conflict(), 0.0);
}

TEST_F(ReconcilerViewTest, AnInstanceWhereTheCameraSawThroughItIsNotListed) {
  const Eigen::Isometry3f pose = At({0, 0, 1});
  Observe(pose);
  RenderDepth(pose, 3);  // the wall 3 m away, and no object in front of it
  std::fill(depth_.pixels.begin(), depth_.pixels.end(), 3000);
  EXPECT_EQ(Reconcile(pose.translation()), 0);  // never visible: no event
  EXPECT_TRUE(EventTypes().empty());
  Instance i = Only();
  EXPECT_EQ(i.view_agree, 0u);
  EXPECT_EQ(i.view_conflict, 6u);
  EXPECT_EQ(ToProto(i, &model_, "m").view_conflict(), 1.0);
  // A second keyframe sees it where it is: the counts are over every keyframe, and the
  // first one's conflict keeps it from being listed.
  perception::DepthImage seen_through = depth_;
  RenderDepth(pose, 0);
  ViewFrame first = view_;
  first.depth = &seen_through;
  const ViewFrame both[] = {first, view_};
  EXPECT_EQ(ReconcileInViews(pose.translation(), both), 0);
  i = Only();
  EXPECT_EQ(i.view_conflict, 6u);
  EXPECT_GE(i.view_agree, 4u);
  EXPECT_GT(ViewConflict(i), 0.15f);
  // Counted again where only the second one is kept (it replaced the first): listed.
  EXPECT_EQ(Reconcile(pose.translation()), 1);
  EXPECT_EQ(Only().view_conflict, 0u);
  EXPECT_EQ(EventTypes(), std::vector<v1::InstanceEvent::Type>{v1::InstanceEvent::CREATED});
}

TEST_F(ReconcilerViewTest, AnInstanceBehindWhatTheCameraSawIsOccludedNotContradicted) {
  const Eigen::Isometry3f pose = At({0, 0, 1});
  Observe(pose);
  std::fill(depth_.pixels.begin(), depth_.pixels.end(), 500);  // something 0.5 m away
  EXPECT_EQ(Reconcile(pose.translation()), 1);
  const Instance i = Only();
  EXPECT_EQ(i.view_agree + i.view_conflict, 0u);
}

// Points nearer than the sensor's range say nothing (it cannot have measured there), and
// points at the camera's centre do not overflow the projection (UBSan runs this).
TEST_F(ReconcilerViewTest, PointsNearerThanTheSensorsRangeCountForNeither) {
  std::fill(depth_.pixels.begin(), depth_.pixels.end(), 500);  // a wall 0.5 m away
  view_.min_depth = 0.1;
  for (const float z : {1e-20f, 1e-6f, 0.05f}) {
    uint32_t agree = 0, conflict = 0;
    CountView(model_.object(0), At({0, 0, z}), view_, &agree, &conflict);
    EXPECT_EQ(agree + conflict, 0u) << z;
  }
  // Within the range the same wall contradicts the object (the check is live).
  uint32_t agree = 0, conflict = 0;
  CountView(model_.object(0), At({0, 0, 0.2f}), view_, &agree, &conflict);
  EXPECT_EQ(agree, 0u);
  EXPECT_EQ(conflict, 6u);
}

// Keyframes that do not look at an instance are skipped whole; one that sees part of it
// (its centre beyond the image's edge) still counts that part.
TEST_F(ReconcilerViewTest, AViewCountsTheObjectsPointsInsideItsImageOnly) {
  std::fill(depth_.pixels.begin(), depth_.pixels.end(), 3000);  // a wall 3 m away
  const recognition::ObjectShape& shape = model_.object(0);
  auto count = [&](const Eigen::Isometry3f& pose) {
    uint32_t agree = 0, conflict = 0;
    CountView(shape, pose, view_, &agree, &conflict);
    return std::pair{agree, conflict};
  };
  // The points whose pixel lies inside the image, by brute force.
  auto inside = [&](const Eigen::Isometry3f& pose) {
    uint32_t n = 0;
    for (const recognition::SurfacePoint& p : shape.surface) {
      const Eigen::Vector3f q = pose * p.p;
      const long u = std::lround(50.0 * q.x() / q.z() + 32.0);
      const long v = std::lround(50.0 * q.y() / q.z() + 24.0);
      n += u >= 0 && u < 64 && v >= 0 && v < 48;
    }
    return n;
  };
  // Slide the object across the right edge (u = 64 at x = 0.64 z) at 1 m.
  int partly = 0;
  for (float x = 0.55f; x <= 0.80f; x += 0.005f) {
    const Eigen::Isometry3f pose = At(Eigen::Vector3f(x, 0, 1) - shape.centre);
    const auto [agree, conflict] = count(pose);
    EXPECT_EQ(agree, 0u);
    // Every point inside sees the wall behind it in 6 or more of its 9 pixels.
    EXPECT_EQ(conflict, inside(pose)) << x;
    partly += inside(pose) > 0 && inside(pose) < shape.surface.size();
  }
  EXPECT_GT(partly, 0);
  // Far beside the image, and behind the camera: nothing.
  EXPECT_EQ(count(At({3, 0, 1})), (std::pair<uint32_t, uint32_t>{0, 0}));
  EXPECT_EQ(count(At({0, 0, -1})), (std::pair<uint32_t, uint32_t>{0, 0}));
}

// Surface normals of the trained voxels (recognition_model.h SurfacePoint::normal) and the
// view check's grazing rule: a 7 x 7 cm plate (flat: its normals are its axis) and a rod
// (no plane: no normal).
TEST(SurfaceNormalsTest, APlatesPointsHaveItsAxisAsNormalAndARodNone) {
  std::vector<VoxelKey> plate, rod;
  for (int x = -3; x <= 3; ++x) {
    for (int y = -3; y <= 3; ++y) plate.push_back({x, y, 0});
  }
  for (int x = -24; x <= 24; ++x) rod.push_back({x, 0, 0});
  const auto db =
      std::make_shared<objects::ObjectDatabase>(objects::SmallOrbDatabase({plate}, true));
  const auto rod_db =
      std::make_shared<objects::ObjectDatabase>(objects::SmallOrbDatabase({rod}, true));
  const recognition::RecognitionModel model = *recognition::RecognitionModel::Create(db, {});
  const recognition::RecognitionModel rod_model =
      *recognition::RecognitionModel::Create(rod_db, {});
  ASSERT_EQ(model.object(0).surface.size(), 49u);  // corners too: their neighbours are flat
  for (const recognition::SurfacePoint& s : model.object(0).surface) {
    EXPECT_NEAR(std::abs(s.normal.z()), 1.0f, 1e-4f) << s.p.transpose();
  }
  ASSERT_EQ(rod_model.object(0).surface.size(), 49u);
  for (const recognition::SurfacePoint& s : rod_model.object(0).surface) {
    EXPECT_TRUE(s.normal.isZero()) << s.p.transpose();
  }
  // At the key range's edge: a rod at z = kMaxKey and one at (y + 1, z = kMinKey), where a
  // packed key one past kMaxKey would land. Still two rods: no normal on either.
  std::vector<VoxelKey> edge_rods;
  for (int x = -12; x < 12; ++x) {
    edge_rods.push_back({x, 0, kMaxKey});
    edge_rods.push_back({x, 1, kMinKey});
  }
  const recognition::RecognitionModel edge_model = *recognition::RecognitionModel::Create(
      std::make_shared<objects::ObjectDatabase>(objects::SmallOrbDatabase({edge_rods}, true)), {});
  ASSERT_EQ(edge_model.object(0).surface.size(), edge_rods.size());
  for (const recognition::SurfacePoint& s : edge_model.object(0).surface) {
    EXPECT_TRUE(s.normal.isZero()) << s.p.transpose() << " / " << s.normal.transpose();
  }

  // Seen face-on at 1 m in front of a wall 3 m away, every point contradicts the wall; seen
  // edge-on (the plate turned 90 degrees about y: the view rays graze it) none counts.
  perception::DepthImage wall;
  wall.width = 64;
  wall.height = 48;
  wall.pixels.assign(64 * 48, 3000);
  const ViewFrame view{
      .depth = &wall,
      .depth_scale = 0.001,
      .camera = {.fx = 50, .fy = 50, .cx = 32, .cy = 24, .width = 64, .height = 48}};
  Eigen::Isometry3f face_on = Eigen::Isometry3f::Identity();
  face_on.translation() = Eigen::Vector3f(0, 0, 1);
  Eigen::Isometry3f edge_on = face_on;
  edge_on.linear() =
      Eigen::AngleAxisf(static_cast<float>(M_PI / 2), Eigen::Vector3f::UnitY()).toRotationMatrix();
  uint32_t agree = 0, conflict = 0;
  CountView(model.object(0), face_on, view, &agree, &conflict);
  EXPECT_EQ(agree, 0u);
  EXPECT_EQ(conflict, 49u);
  agree = conflict = 0;
  CountView(model.object(0), edge_on, view, &agree, &conflict);
  EXPECT_EQ(agree + conflict, 0u);
  // A rod has no normal: it counts from any side (what the check did for every point).
  CountView(rod_model.object(0), edge_on, view, &agree, &conflict);
  EXPECT_EQ(conflict, 49u);
}

// The score asked of an instance grows with the square root of its object's trained
// surface (recognition_config.h InstanceVisibility): min_score at 0.04 m².
TEST(VisibilityTest, TheScoreAskedGrowsWithTheSquareRootOfTheObjectsSurface) {
  const InstanceVisibility visible{.min_score = 40, .min_fit = 0, .max_view_conflict = 1};
  EXPECT_DOUBLE_EQ(visible.MinScore(0.04), 40);
  EXPECT_DOUBLE_EQ(visible.MinScore(0.01), 20);
  EXPECT_DOUBLE_EQ(visible.MinScore(0.16), 80);
  EXPECT_DOUBLE_EQ(visible.MinScore(0), 40);  // unknown: unscaled
  std::vector<VoxelKey> plate;  // 7 x 7 voxels of 1 cm: 0.0049 m², asked 40 * 0.35 = 14
  for (int x = -3; x <= 3; ++x) {
    for (int y = -3; y <= 3; ++y) plate.push_back({x, y, 0});
  }
  const recognition::RecognitionModel model = *recognition::RecognitionModel::Create(
      std::make_shared<objects::ObjectDatabase>(objects::SmallOrbDatabase({plate}, true)), {});
  EXPECT_NEAR(model.object(0).surface_area, 0.0049f, 1e-6f);
  Instance i;
  i.object_id = kObjId;
  i.fit = 1;
  i.score = 15;
  EXPECT_TRUE(IsVisible(visible, i, &model));
  i.score = 13;
  EXPECT_FALSE(IsVisible(visible, i, &model));
  i.score = 39;  // without the model, or of an object it does not hold: 40 asked
  EXPECT_FALSE(IsVisible(visible, i, nullptr));
  i.object_id = kObjId + 7;
  EXPECT_FALSE(IsVisible(visible, i, &model));
  i.score = 40;
  EXPECT_TRUE(IsVisible(visible, i, &model));
  // A stored surface at an absurd resolution (1e200 m: the area overflows a float; 1e-30 m:
  // it underflows) has an unknown area: the unscaled 40 is asked, nothing NaN.
  for (const double resolution : {1e200, 1e-30}) {
    const recognition::RecognitionModel odd = *recognition::RecognitionModel::Create(
        std::make_shared<objects::ObjectDatabase>(
            objects::SmallOrbDatabase({plate}, true, resolution)),
        {});
    EXPECT_EQ(odd.object(0).surface_area, 0.0f) << resolution;
    EXPECT_EQ(odd.object(0).surface.size(), 49u);
    i.object_id = kObjId;
    i.score = 39;
    EXPECT_FALSE(IsVisible(visible, i, &odd)) << resolution;
    i.score = 40;
    EXPECT_TRUE(IsVisible(visible, i, &odd)) << resolution;
  }
}

// A map that leaves its thresholds unset lists with its classifier's: an ORB database
// brings ORB's (objects::DefaultInstanceThresholds), a map's own value wins.
TEST(VisibilityTest, UnsetThresholdsAreTheClassifiersOwn) {
  const recognition::RecognitionModel model = *recognition::RecognitionModel::Create(
      std::make_shared<objects::ObjectDatabase>(objects::SmallOrbDatabase({{{0, 0, 0}}}, true)),
      {});
  const InstanceVisibility orb = ResolveVisibility({}, &model);
  EXPECT_EQ(orb.min_score, 112);
  EXPECT_EQ(orb.min_fit, 0.4);
  EXPECT_EQ(orb.max_view_conflict, 0.02);
  const InstanceVisibility own = ResolveVisibility({.min_fit = 0.1}, &model);
  EXPECT_EQ(own.min_score, 112);
  EXPECT_EQ(own.min_fit, 0.1);
  const InstanceVisibility none = ResolveVisibility({}, nullptr);  // the default detector's
  EXPECT_EQ(none.min_score, 52);
}

}  // namespace
}  // namespace skimap::server
