// The one absl::Status -> HTTP mapping (server/http/http_status.h) and the REST message
// helpers (server/http/rest_messages.h): query parameters onto request fields.
#include "server/http/http_status.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <map>
#include <string>

#include "server/http/rest_messages.h"
#include "skimap/v1/instances.pb.h"
#include "skimap/v1/objects.pb.h"
#include "skimap/v1/queries.pb.h"

namespace skimap::server {
namespace {

using ::testing::HasSubstr;

TEST(HttpStatusTest, EveryStatusCodeHasItsHttpCode) {
  const std::map<absl::StatusCode, int> expected = {
      {absl::StatusCode::kOk, 200},
      {absl::StatusCode::kCancelled, 500},
      {absl::StatusCode::kUnknown, 500},
      {absl::StatusCode::kInvalidArgument, 400},
      {absl::StatusCode::kDeadlineExceeded, 504},
      {absl::StatusCode::kNotFound, 404},
      {absl::StatusCode::kAlreadyExists, 409},
      {absl::StatusCode::kPermissionDenied, 403},
      {absl::StatusCode::kResourceExhausted, 429},
      {absl::StatusCode::kFailedPrecondition, 409},
      {absl::StatusCode::kAborted, 409},
      {absl::StatusCode::kOutOfRange, 400},
      {absl::StatusCode::kUnimplemented, 501},
      {absl::StatusCode::kInternal, 500},
      {absl::StatusCode::kUnavailable, 503},
      {absl::StatusCode::kDataLoss, 500},
      {absl::StatusCode::kUnauthenticated, 401},
  };
  for (const auto& [code, http] : expected) {
    EXPECT_EQ(ToHttpStatus(absl::Status(code, "x")), http) << absl::StatusCodeToString(code);
  }
}

TEST(HttpStatusTest, OnlyATooLargeBodyIs413) {
  EXPECT_EQ(ToHttpStatus(absl::ResourceExhaustedError("write queue full")), 429);
  const absl::Status too_large = BodyTooLargeError("body: 5 MiB");
  EXPECT_EQ(too_large.code(), absl::StatusCode::kResourceExhausted);
  EXPECT_EQ(ToHttpStatus(too_large), 413);
}

TEST(HttpStatusTest, RestErrorCarriesCodeNameAndACappedMessage) {
  const v1::RestError e = ToRestError(absl::NotFoundError("map maps/x not found"));
  EXPECT_EQ(e.code(), 404);
  EXPECT_EQ(e.status(), "NOT_FOUND");
  EXPECT_EQ(e.message(), "map maps/x not found");
  EXPECT_EQ(ToRestError(absl::UnimplementedError("method"), 405).code(), 405);
  const v1::RestError long_one = ToRestError(absl::InvalidArgumentError(std::string(5000, 'a')));
  EXPECT_EQ(long_one.message().size(), 1024u + 3);
}

using Params = std::multimap<std::string, std::string>;

TEST(QueryParametersTest, NamesAreJsonOrProtoNamesWithDotsForNestedFields) {
  v1::GetOccupancyGridRequest r;
  ASSERT_TRUE(FromQueryParameters({{"bandMinZ", "0.1"},
                                   {"band_max_z", "1.2"},
                                   {"region.minX", "-1"},
                                   {"region.max_y", "2.5"},
                                   {"minVoxelWeight", "3"}},
                                  {"map"}, {}, &r)
                  .ok());
  EXPECT_DOUBLE_EQ(r.band_min_z(), 0.1);
  EXPECT_DOUBLE_EQ(r.band_max_z(), 1.2);
  EXPECT_TRUE(r.has_region());
  EXPECT_DOUBLE_EQ(r.region().min_x(), -1);
  EXPECT_DOUBLE_EQ(r.region().max_y(), 2.5);
  EXPECT_FLOAT_EQ(r.min_voxel_weight(), 3);
  EXPECT_FALSE(r.has_floor_min_z());  // absent parameters leave optional fields unset
}

TEST(QueryParametersTest, AMessageAsOneCommaListFillsItsNumbersInOrder) {
  v1::ListInstancesRequest r;
  ASSERT_TRUE(FromQueryParameters({{"sphere", "1, 2,3,0.5"}, {"objIds", "4,5"}, {"objIds", "6"}},
                                  {"map"}, {}, &r)
                  .ok());
  ASSERT_TRUE(r.has_sphere());
  EXPECT_DOUBLE_EQ(r.sphere().center().y(), 2);
  EXPECT_DOUBLE_EQ(r.sphere().radius(), 0.5);
  EXPECT_THAT(r.obj_ids(), ::testing::ElementsAre(4, 5, 6));
  ASSERT_TRUE(FromQueryParameters({{"box", "0,0,0,1,1,1"}}, {"map"}, {}, &r).ok());
  EXPECT_TRUE(r.has_box());  // the oneof moved to the box
  EXPECT_FALSE(r.has_sphere());
}

TEST(QueryParametersTest, EnumsByNameOrNumber) {
  v1::GetObjectRequest r;
  ASSERT_TRUE(FromQueryParameters({{"view", "OBJECT_VIEW_FULL"}}, {"name"}, {}, &r).ok());
  EXPECT_EQ(r.view(), v1::OBJECT_VIEW_FULL);
  ASSERT_TRUE(FromQueryParameters({{"view", "1"}}, {"name"}, {}, &r).ok());
  EXPECT_EQ(r.view(), v1::OBJECT_VIEW_BASIC);
}

TEST(QueryParametersTest, ErrorsNameTheParameter) {
  const std::vector<std::pair<Params, std::string>> cases = {
      {{{"pageSize", "ten"}}, "query parameter pageSize: \"ten\" is not a int32"},
      {{{"pageSize", "99999999999"}}, "query parameter pageSize"},
      {{{"box", "1,2"}},
       "query parameter box: expected 6 comma-separated numbers "
       "(min.x,min.y,min.z,max.x,max.y,max.z), got \"1,2\""},
      {{{"box.min", "1"}}, "query parameter box.min: expected 3"},
      {{{"box.min.w", "1"}}, "query parameter box.min.w: unknown"},
      {{{"pageSize.x", "1"}}, "query parameter pageSize.x: pageSize has no fields"},
      {{{"map", "maps/a"}}, "query parameter map: unknown; this route takes box, pageSize"},
      {{{"minVoxelWeight", "1"}, {"minVoxelWeight", "2"}}, "given 2 times"},
      {{{std::string(200, 'z'), "1"}}, "query parameter \"zzzz"},
  };
  for (const auto& [params, message] : cases) {
    v1::GetVoxelsRequest r;
    const absl::Status s = FromQueryParameters(params, {"map"}, {}, &r);
    EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << message;
    EXPECT_THAT(s.message(), HasSubstr(message));
  }
}

TEST(QueryParametersTest, RouteParametersAreLeftToTheRoute) {
  v1::GetHeightMapRequest r;
  EXPECT_TRUE(FromQueryParameters({{"format", "png"}}, {"map"}, {"format"}, &r).ok());
  EXPECT_FALSE(FromQueryParameters({{"format", "png"}}, {"map"}, {}, &r).ok());
}

TEST(JsonBodyTest, TheParserNamesTheField) {
  v1::RadiusSearchRequest r;
  const absl::Status s = FromJsonBody(R"({"center": {"x": "left"}})", &r);
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(s.message(), HasSubstr("body: "));
  EXPECT_THAT(s.message(), HasSubstr("center.x"));
  v1::RadiusSearchRequest ok;
  ASSERT_TRUE(FromJsonBody(R"({"center": {"x": 1.5}, "radius": 2, "maxResults": 7})", &ok).ok());
  EXPECT_EQ(ok.max_results(), 7);
  // Zeros are printed too, so a client finds every field.
  EXPECT_THAT(ToJson(ok), HasSubstr(R"("center":{"x":1.5,"y":0,"z":0},"radius":2,"maxResults":7)"));
  EXPECT_THAT(ToJson(ok), HasSubstr(R"("map":"")"));
}

TEST(PathFieldTest, ThePathAndTheBodyMustAgree) {
  v1::RadiusSearchRequest r;
  EXPECT_TRUE(BindPathField("map", "maps/a", &r).ok());
  EXPECT_EQ(r.map(), "maps/a");
  EXPECT_TRUE(BindPathField("map", "maps/a", &r).ok());
  const absl::Status s = BindPathField("map", "maps/b", &r);
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(s.message(), HasSubstr("map: the body names \"maps/a\", the path \"maps/b\""));
}

}  // namespace
}  // namespace skimap::server
