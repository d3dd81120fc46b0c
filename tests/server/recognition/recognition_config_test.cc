// RecognitionOptions' defaults: what a map gets when the client sets only `enabled`.
#include "server/core/recognition/recognition_config.h"

#include <gtest/gtest.h>

#include "perception/objects/object_database.h"

namespace skimap::server {
namespace {

TEST(RecognitionConfigTest, DefaultsAreTheDocumentedOnes) {
  v1::RecognitionOptions o;
  o.set_enabled(true);
  absl::StatusOr<RecognitionConfig> c = ResolveRecognitionOptions(o);
  ASSERT_TRUE(c.ok()) << c.status();
  // The scene rule (the sphere follows what the camera looks at, near or far): a fixed
  // sphere 1 m ahead never reached the objects a robot sees from 2-3 m (docs/recognition.md).
  EXPECT_EQ(c->sphere_distance, 0);
  EXPECT_EQ(c->sphere_radius, 0.6);
  EXPECT_EQ(c->triples, 2000);
  EXPECT_EQ(c->labels_resolution, 0.005);
  const v1::RecognitionOptions back = ToProto(*c);
  EXPECT_EQ(back.sphere_distance(), 0);
  EXPECT_EQ(back.triples(), 2000u);
  // The visibility thresholds are left to the classifier.
  EXPECT_FALSE(back.has_min_instance_score());
  EXPECT_FALSE(back.has_min_instance_fit());
  EXPECT_FALSE(back.has_max_view_conflict());
}

TEST(RecognitionConfigTest, AMapListsWithItsClassifiersThresholdsUnlessItSetsItsOwn) {
  v1::RecognitionOptions o;
  o.set_enabled(true);
  absl::StatusOr<RecognitionConfig> c = ResolveRecognitionOptions(o);
  ASSERT_TRUE(c.ok()) << c.status();
  // No classifier loaded: the default detector's (SIFT).
  InstanceVisibility v = c->visible.Resolve(nullptr);
  EXPECT_EQ(v.min_score, 52);
  EXPECT_EQ(v.min_fit, 0.3);
  EXPECT_EQ(v.max_view_conflict, 0.1);
  // An ORB classifier: ORB's, as its database stores them.
  const objects::InstanceThresholds orb = objects::DefaultInstanceThresholds("ORB");
  v = c->visible.Resolve(&orb);
  EXPECT_EQ(v.min_score, 112);
  EXPECT_EQ(v.min_fit, 0.4);
  EXPECT_EQ(v.max_view_conflict, 0.02);
  // The map's own values win, one by one, and are kept in its options.
  o.set_min_instance_score(30);
  o.set_max_view_conflict(1);
  c = ResolveRecognitionOptions(o);
  ASSERT_TRUE(c.ok()) << c.status();
  v = c->visible.Resolve(&orb);
  EXPECT_EQ(v.min_score, 30);
  EXPECT_EQ(v.min_fit, 0.4);
  EXPECT_EQ(v.max_view_conflict, 1);
  const v1::RecognitionOptions back = ToProto(*c);
  EXPECT_EQ(back.min_instance_score(), 30);
  EXPECT_FALSE(back.has_min_instance_fit());
  EXPECT_EQ(back.max_view_conflict(), 1);
}

TEST(RecognitionConfigTest, AFixedSphereIsStillAvailable) {
  v1::RecognitionOptions o;
  o.set_enabled(true);
  o.set_sphere_distance(1.0);
  absl::StatusOr<RecognitionConfig> c = ResolveRecognitionOptions(o);
  ASSERT_TRUE(c.ok()) << c.status();
  EXPECT_EQ(c->sphere_distance, 1.0);
  o.set_sphere_distance(-1);
  EXPECT_EQ(ResolveRecognitionOptions(o).status().code(), absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace skimap::server
