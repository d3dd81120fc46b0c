// The object database's reads and a recognition map's instances over REST: one sim `mini`
// object trained through the object service (a gRPC stream, as a robot would), a small
// classifier built, then every read through the REST routes.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "absl/strings/str_cat.h"
#include "client/object_client.h"
#include "tests/server/http/rest_fixture.h"
#include "tests/server/objects/object_service_fixture.h"

namespace skimap::testing {
namespace {

using ::testing::HasSubstr;

TEST(RestObjectsTest, ObjectsAndTheInstancesOfARecognitionMap) {
  RestServer rest;
  httplib::Client& http = rest.http();
  // Before any object: a recognition map cannot be created (no classifier).
  EXPECT_EQ(ParseError(http.Post("/v1/maps", R"({"mapId": "early", "options":
                                     {"recognition": {"enabled": true}}})",
                                 kJson),
                       409)
                .status(),
            "FAILED_PRECONDITION");

  auto c = client::ObjectClient::Connect(absl::StrCat("127.0.0.1:", rest.server().grpc_port()));
  absl::StatusOr<v1::Object> trained = Train(*c, 1, MiniViews(1, 3));
  ASSERT_TRUE(trained.ok()) << trained.status();
  v1::BuildClassifierRequest build;
  build.mutable_params()->set_classes_per_object(50);
  build.mutable_params()->set_trees(4);
  build.mutable_params()->set_max_depth(12);
  absl::StatusOr<v1::Operation> op = c->BuildClassifier(build);
  ASSERT_TRUE(op.ok()) << op.status();
  op = c->WaitDone(
      op->name(), [](const v1::Operation&) {}, absl::Milliseconds(200));
  ASSERT_TRUE(op.ok()) << op.status();

  const auto objects = ParseJson<v1::ListObjectsResponse>(http.Get("/v1/objects"));
  ASSERT_EQ(objects.objects_size(), 1);
  EXPECT_EQ(objects.objects(0).name(), "objects/1");
  EXPECT_EQ(objects.objects(0).voxels(), trained->voxels());
  const auto basic = ParseJson<v1::Object>(http.Get("/v1/objects/1"));
  EXPECT_TRUE(basic.in_classifier());
  EXPECT_EQ(basic.rgb_voxels_size(), 0);
  const auto full = ParseJson<v1::Object>(http.Get("/v1/objects/1?view=OBJECT_VIEW_FULL"));
  EXPECT_GT(full.rgb_voxels_size(), 0);
  EXPECT_THAT(ParseError(http.Get("/v1/objects/2"), 404).message(), HasSubstr("objects/2"));

  const auto map = ParseJson<v1::Map>(http.Post(
      "/v1/maps", R"({"mapId": "seen", "options": {"recognition": {"enabled": true}}})", kJson));
  EXPECT_TRUE(map.options().recognition().enabled());
  // No frame yet: no instance, wherever asked.
  for (const char* query :
       {"", "?box=-1,-1,-1,1,1,1&objIds=1&minScore=10&pageSize=5", "?sphere=0,0,0,2"}) {
    const auto listed = ParseJson<v1::ListInstancesResponse>(
        http.Get(absl::StrCat("/v1/maps/seen/instances", query)));
    EXPECT_EQ(listed.instances_size(), 0) << query;
    EXPECT_TRUE(listed.next_page_token().empty());
  }
  const v1::RestError unknown = ParseError(http.Get("/v1/maps/seen/instances/42"), 404);
  EXPECT_EQ(unknown.status(), "NOT_FOUND");
  EXPECT_THAT(unknown.message(), HasSubstr("instance 42"));
  EXPECT_EQ(ParseError(http.Get("/v1/maps/seen/instances/forty-two"), 400).status(),
            "INVALID_ARGUMENT");
  EXPECT_THAT(ParseError(http.Get("/v1/maps/seen/instances?sphere=0,0,0,-1"), 400).message(),
              HasSubstr("sphere"));
}

}  // namespace
}  // namespace skimap::testing
