// The Labels volume over REST (GET /v1/maps/{map}/labels) and gRPC (GetLabelVoxels): a sim
// `mini` object trained through the object service, a small classifier built, and views of
// that object posted as frames of a map with recognition (policy EVERY_FRAME: each frame's
// labels are in the map before its ack). The REST reply is the gRPC reply, pages add up to
// the map's label_voxels, the filters select what they say, and every bad request gets its
// error naming the field.
#include <gmock/gmock.h>
#include <google/protobuf/util/message_differencer.h>
#include <gtest/gtest.h>

#include <cctype>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "client/cli/dataset_frames.h"
#include "client/map_client.h"
#include "client/object_client.h"
#include "dataset/reader.h"
#include "tests/server/http/rest_fixture.h"
#include "tests/server/objects/object_service_fixture.h"

namespace skimap::testing {
namespace {

using ::testing::HasSubstr;

// `s` percent-encoded for a query parameter (page tokens are base64).
std::string UrlEncode(const std::string& s) {
  std::string out;
  for (unsigned char c : s) {
    if (std::isalnum(c) || c == '-' || c == '_' || c == '.' || c == '~') {
      out += char(c);
    } else {
      out += absl::StrFormat("%%%02X", c);
    }
  }
  return out;
}

// Every label voxel of maps/seen over REST, `page_size` at a time, with `query` added.
std::vector<v1::LabelVoxel> AllLabels(httplib::Client& http, int page_size,
                                      const std::string& query = "") {
  std::vector<v1::LabelVoxel> out;
  std::string token;
  for (int pages = 0; pages < 10000; ++pages) {
    const auto page = ParseJson<v1::GetLabelVoxelsResponse>(
        http.Get(absl::StrCat("/v1/maps/seen/labels?pageSize=", page_size, query,
                              token.empty() ? "" : absl::StrCat("&pageToken=", UrlEncode(token)))));
    out.insert(out.end(), page.voxels().begin(), page.voxels().end());
    token = page.next_page_token();
    if (token.empty()) break;
  }
  return out;
}

TEST(RestLabelsTest, TheLabelsVolumeOfARecognitionMapOverRestAndGrpc) {
  RestServer rest;
  httplib::Client& http = rest.http();
  const std::string grpc_address = absl::StrCat("127.0.0.1:", rest.server().grpc_port());
  auto objects = client::ObjectClient::Connect(grpc_address);
  ASSERT_TRUE(Train(*objects, 1, MiniViews(1, 2)).ok());
  v1::BuildClassifierRequest build;
  build.mutable_params()->set_classes_per_object(50);
  build.mutable_params()->set_trees(6);
  build.mutable_params()->set_max_depth(14);
  absl::StatusOr<v1::Operation> op = objects->BuildClassifier(build);
  ASSERT_TRUE(op.ok()) << op.status();
  ASSERT_TRUE(objects->WaitDone(op->name(), nullptr, absl::Milliseconds(100)).ok());

  ParseJson<v1::Map>(http.Post("/v1/maps", R"({"mapId": "plain"})", kJson));
  ParseJson<v1::Map>(http.Post("/v1/maps", R"({"mapId": "seen", "options": {"resolution": 0.01,
                        "recognition": {"enabled": true, "policy": "EVERY_FRAME"}}})",
                               kJson));
  // Before any frame: an empty volume, one empty page.
  const auto empty = ParseJson<v1::GetLabelVoxelsResponse>(http.Get("/v1/maps/seen/labels"));
  EXPECT_EQ(empty.voxels_size(), 0);
  EXPECT_TRUE(empty.next_page_token().empty());
  EXPECT_DOUBLE_EQ(empty.resolution(), 0.005);  // RecognitionOptions.labels_resolution

  // Views of object 1 (the held-out ones) as frames of the map.
  absl::StatusOr<dataset::Sequence> seq =
      dataset::LoadBopScene(absl::StrFormat("%s/train/%06d", objects::testing::MiniDataset(), 1));
  ASSERT_TRUE(seq.ok()) << seq.status();
  uint64_t sequence = 0;
  for (const dataset::Frame& f : seq->frames) {
    if (!objects::testing::HeldOutView(1, f.id)) continue;
    absl::StatusOr<v1::Frame> frame = client::ToApiFrame(f, "maps/seen", ++sequence);
    ASSERT_TRUE(frame.ok()) << frame.status();
    const auto ack =
        ParseJson<v1::FrameAck>(http.Post("/v1/maps/seen/frames", ToJsonBody(*frame), kJson));
    ASSERT_EQ(ack.code(), 0) << ack.message();
  }
  const auto map = ParseJson<v1::Map>(http.Get("/v1/maps/seen"));
  ASSERT_GT(map.stats().label_voxels(), 20u) << "the views' features were not labelled";

  // Every voxel, in small pages: as many as the map's stats say, each one sane.
  const std::vector<v1::LabelVoxel> all = AllLabels(http, 7);
  EXPECT_EQ(all.size(), map.stats().label_voxels());
  const v1::Box3& bounds = map.stats().bounds();
  for (const v1::LabelVoxel& v : all) {
    EXPECT_GE(v.count(), 1u);
    EXPECT_LE(v.count(), v.total());
    EXPECT_LT(v.label(), 50u);  // the classifier's classes: 50 for its one object
    EXPECT_EQ(v.obj_id(), 1);   // every class belongs to the one object
    // Labels sit on observed surfaces: inside the RGB volume's bounds (plus a voxel).
    EXPECT_GE(v.center().x(), bounds.min().x() - 0.01);
    EXPECT_LE(v.center().x(), bounds.max().x() + 0.01);
    EXPECT_GE(v.center().z(), bounds.min().z() - 0.01);
    EXPECT_LE(v.center().z(), bounds.max().z() + 0.01);
  }

  // The gRPC method answers the same page as REST.
  auto maps = client::MapClient::Connect(grpc_address);
  v1::GetLabelVoxelsRequest request;
  request.set_map("maps/seen");
  request.set_page_size(100000);
  grpc::ClientContext context;
  v1::GetLabelVoxelsResponse by_grpc;
  ASSERT_TRUE(maps->stub().GetLabelVoxels(&context, request, &by_grpc).ok());
  const auto by_rest =
      ParseJson<v1::GetLabelVoxelsResponse>(http.Get("/v1/maps/seen/labels?pageSize=100000"));
  EXPECT_TRUE(google::protobuf::util::MessageDifferencer::Equals(by_grpc, by_rest));
  EXPECT_EQ(by_rest.voxels_size(), static_cast<int>(all.size()));

  // Filters: minCount keeps exactly the voxels seen that often; a box exactly those inside.
  size_t twice = 0;
  for (const v1::LabelVoxel& v : all) twice += v.count() >= 2;
  const std::vector<v1::LabelVoxel> repeated = AllLabels(http, 5, "&minCount=2");
  EXPECT_EQ(repeated.size(), twice);
  for (const v1::LabelVoxel& v : repeated) EXPECT_GE(v.count(), 2u);
  const double mid_x = (bounds.min().x() + bounds.max().x()) / 2;
  size_t left = 0;
  for (const v1::LabelVoxel& v : all) left += v.center().x() <= mid_x;
  const std::vector<v1::LabelVoxel> boxed =
      AllLabels(http, 9, absl::StrCat("&box=-100,-100,-100,", mid_x, ",100,100"));
  EXPECT_EQ(boxed.size(), left);
  for (const v1::LabelVoxel& v : boxed) EXPECT_LE(v.center().x(), mid_x);

  // Errors, each naming its field.
  const v1::RestError plain = ParseError(http.Get("/v1/maps/plain/labels"), 409);
  EXPECT_EQ(plain.status(), "FAILED_PRECONDITION");
  EXPECT_THAT(plain.message(), HasSubstr("recognition"));
  EXPECT_EQ(ParseError(http.Get("/v1/maps/nowhere/labels"), 404).status(), "NOT_FOUND");
  EXPECT_THAT(ParseError(http.Get("/v1/maps/seen/labels?pageSize=-1"), 400).message(),
              HasSubstr("page_size"));
  EXPECT_THAT(ParseError(http.Get("/v1/maps/seen/labels?pageSize=100001"), 400).message(),
              HasSubstr("page_size"));
  EXPECT_THAT(ParseError(http.Get("/v1/maps/seen/labels?box=1,1,1,0,0,0"), 400).message(),
              HasSubstr("box"));
  EXPECT_THAT(ParseError(http.Get("/v1/maps/seen/labels?pageToken=garbage"), 400).message(),
              HasSubstr("page_token"));
  EXPECT_THAT(ParseError(http.Get("/v1/maps/seen/labels?minCount=-3"), 400).message(),
              HasSubstr("minCount"));
  // A token is bound to its query: another minCount refuses it.
  const auto first =
      ParseJson<v1::GetLabelVoxelsResponse>(http.Get("/v1/maps/seen/labels?pageSize=3"));
  ASSERT_FALSE(first.next_page_token().empty());
  EXPECT_THAT(
      ParseError(http.Get(absl::StrCat("/v1/maps/seen/labels?pageSize=3&minCount=2&pageToken=",
                                       UrlEncode(first.next_page_token()))),
                 400)
          .message(),
      HasSubstr("page_token"));
}

}  // namespace
}  // namespace skimap::testing
