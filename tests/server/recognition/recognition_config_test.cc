// RecognitionOptions' defaults: what a map gets when the client sets only `enabled`.
#include "server/core/recognition/recognition_config.h"

#include <gtest/gtest.h>

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
