// Round trips through every REST route of an in-process skimapd (real sockets, a real HTTP
// client), fed with the real ycbv-0000 frames posted as JSON; answers compared with the
// map service core's own answers to the same requests.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <opencv2/core.hpp>
#include <set>
#include <string>
#include <vector>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "client/cli/dataset_frames.h"
#include "tests/common/images.h"
#include "tests/server/http/rest_fixture.h"

namespace skimap::testing {
namespace {

using ::testing::HasSubstr;

class RestApiTest : public ::testing::Test {
 protected:
  // One server for the suite, holding map "ycbv": the ten real frames, posted one by one.
  static void SetUpTestSuite() {
    rest_ = new RestServer();
    v1::CreateMapRequest create;
    create.set_map_id("ycbv");
    create.mutable_options()->set_resolution(0.02);
    ParseJson<v1::Map>(rest_->http().Post("/v1/maps", ToJsonBody(create), kJson));
    auto frames = client::LoadDatasetFrames(SKIMAP_YCBV_DIR);
    ASSERT_TRUE(frames.ok()) << frames.status();
    for (size_t i = 0; i < frames->size(); ++i) {
      auto frame = client::ToApiFrame((*frames)[i], "maps/ycbv", i);
      ASSERT_TRUE(frame.ok()) << frame.status();
      frames_.push_back(*frame);
      const v1::FrameAck ack = ParseJson<v1::FrameAck>(
          rest_->http().Post("/v1/maps/ycbv/frames", ToJsonBody(*frame), kJson));
      EXPECT_EQ(ack.code(), 0) << ack.message();
      EXPECT_EQ(ack.sequence(), i);
      EXPECT_GT(ack.points(), 100000u);
    }
  }
  static void TearDownTestSuite() {
    delete rest_;
    rest_ = nullptr;
  }

  httplib::Client& http() { return rest_->http(); }
  server::MapService& core() { return rest_->server().maps(); }

  static inline RestServer* rest_ = nullptr;
  static inline std::vector<v1::Frame> frames_;
};

TEST_F(RestApiTest, HealthzAnswersServing) {
  EXPECT_EQ(ParseJson<v1::HealthzResponse>(http().Get("/healthz")).status(), "SERVING");
}

TEST_F(RestApiTest, PostedFramesAreInTheMap) {
  const v1::Map map = ParseJson<v1::Map>(http().Get("/v1/maps/ycbv"));
  EXPECT_EQ(map.name(), "maps/ycbv");
  EXPECT_DOUBLE_EQ(map.options().resolution(), 0.02);
  EXPECT_EQ(map.stats().frames(), 10u);
  EXPECT_GT(map.stats().voxels(), 1000u);  // 1364 measured (2 cm voxels of a table top)
}

TEST_F(RestApiTest, CreateListGetDeleteAMap) {
  const v1::Map created = ParseJson<v1::Map>(http().Post(
      "/v1/maps",
      R"({"mapId": "kitchen", "options": {"resolution": 0.05, "carveFreeSpace": true}})", kJson));
  EXPECT_EQ(created.name(), "maps/kitchen");
  EXPECT_TRUE(created.options().carve_free_space());
  EXPECT_DOUBLE_EQ(created.options().max_depth(), 5.0);  // defaults filled in

  // Two maps, one per page: the token leads from the first page to the second.
  const auto first = ParseJson<v1::ListMapsResponse>(http().Get("/v1/maps?pageSize=1"));
  ASSERT_EQ(first.maps_size(), 1);
  EXPECT_EQ(first.maps(0).name(), "maps/kitchen");
  ASSERT_FALSE(first.next_page_token().empty());
  const auto second = ParseJson<v1::ListMapsResponse>(
      http().Get(absl::StrCat("/v1/maps?pageSize=1&pageToken=",
                              httplib::detail::encode_query_param(first.next_page_token()))));
  ASSERT_EQ(second.maps_size(), 1);
  EXPECT_EQ(second.maps(0).name(), "maps/ycbv");

  EXPECT_EQ(ParseJson<v1::Map>(http().Get("/v1/maps/kitchen")).name(), "maps/kitchen");
  httplib::Result deleted = http().Delete("/v1/maps/kitchen");
  ParseJson<v1::DeleteMapResponse>(deleted);
  EXPECT_EQ(deleted->body, "{}");
  const v1::RestError gone = ParseError(http().Get("/v1/maps/kitchen"), 404);
  EXPECT_EQ(gone.status(), "NOT_FOUND");
  EXPECT_THAT(gone.message(), HasSubstr("maps/kitchen"));
}

TEST_F(RestApiTest, AJsonBodyIsReadWhateverItsContentType) {
  // `curl -d '{...}'` labels JSON as a form (application/x-www-form-urlencoded): the body
  // is still the request, and its text is not taken for query parameters.
  for (const char* type : {"application/x-www-form-urlencoded", "text/plain"}) {
    const v1::Map map = ParseJson<v1::Map>(http().Post("/v1/maps", R"({"mapId": "form"})", type));
    EXPECT_EQ(map.name(), "maps/form") << type;
    ParseJson<v1::DeleteMapResponse>(http().Delete("/v1/maps/form"));
  }
}

// The grid as JSON, as a ROS map_server PGM and as a PNG: same size, same cells.
TEST_F(RestApiTest, OccupancyGridAsJsonPgmAndPng) {
  const std::string path = "/v1/maps/ycbv/occupancyGrid?bandMinZ=0.02&bandMaxZ=0.3&floorMinZ=-0.05";
  const auto grid = ParseJson<v1::OccupancyGrid>(http().Get(path));
  ASSERT_GT(grid.width(), 10u);
  ASSERT_GT(grid.height(), 10u);
  v1::GetOccupancyGridRequest same;
  same.set_map("maps/ycbv");
  same.set_band_min_z(0.02);
  same.set_band_max_z(0.3);
  same.set_floor_min_z(-0.05);
  auto from_core = core().GetOccupancyGrid(same);
  ASSERT_TRUE(from_core.ok());
  EXPECT_EQ(grid.data(), from_core->data());  // base64 in JSON, the same bytes

  // Expected pixels: ROS trinary, image top = largest y.
  const int w = grid.width(), h = grid.height();
  cv::Mat expected(h, w, CV_8UC1);
  std::map<int, int> counts;
  for (int row = 0; row < h; ++row) {
    for (int i = 0; i < w; ++i) {
      const int8_t cell = grid.data()[size_t(h - 1 - row) * w + i];
      expected.at<uint8_t>(row, i) = cell < 0 ? 205 : cell >= 50 ? 0 : 254;
      ++counts[expected.at<uint8_t>(row, i)];
    }
  }
  EXPECT_GT(counts[0], 0);    // occupied cells (the objects on the table)
  EXPECT_GT(counts[254], 0);  // free (the table top)

  for (const auto& [query, accept, type] :
       std::vector<std::tuple<std::string, std::string, std::string>>{
           {"&format=pgm", "", "image/x-portable-graymap"},
           {"", "image/x-portable-graymap", "image/x-portable-graymap"},
           {"&format=png", "", "image/png"},
           {"", "image/png", "image/png"}}) {
    SCOPED_TRACE(query + accept);
    httplib::Headers headers;
    if (!accept.empty()) headers.emplace("Accept", accept);
    httplib::Result r = http().Get(path + query, headers);
    ASSERT_TRUE(r);
    ASSERT_EQ(r->status, 200) << r->body;
    EXPECT_EQ(r->get_header_value("Content-Type"), type);
    EXPECT_EQ(r->get_header_value("X-Skimap-Width"), absl::StrCat(w));
    EXPECT_EQ(r->get_header_value("X-Skimap-Height"), absl::StrCat(h));
    double resolution = 0;
    ASSERT_TRUE(absl::SimpleAtod(r->get_header_value("X-Skimap-Resolution"), &resolution));
    EXPECT_DOUBLE_EQ(resolution, 0.02);
    const std::vector<std::string> origin =
        absl::StrSplit(r->get_header_value("X-Skimap-Origin"), ' ');
    ASSERT_EQ(origin.size(), 2u);
    double ox = 0;
    ASSERT_TRUE(absl::SimpleAtod(origin[0], &ox));
    EXPECT_NEAR(ox, grid.origin_x(), 1e-9);
    if (type == "image/x-portable-graymap") {
      // Binary PGM: "P5", width, height, maxval 255, then the pixels.
      const std::string header = absl::StrCat("P5\n", w, " ", h, "\n255\n");
      ASSERT_EQ(r->body.substr(0, header.size()), header);
      EXPECT_EQ(r->body.size(), header.size() + size_t(w) * h);
    }
    const cv::Mat image = ImDecode(r->body, ImageMode::kUnchanged);
    ASSERT_EQ(image.type(), CV_8UC1);
    ASSERT_EQ(image.cols, w);
    ASSERT_EQ(image.rows, h);
    EXPECT_EQ(cv::countNonZero(image != expected), 0);
  }
  // zstd data in JSON (the same grid, fewer bytes); images are refused it, naming the field.
  const auto packed =
      ParseJson<v1::OccupancyGrid>(http().Get(path + "&dataEncoding=GRID_ENCODING_ZSTD"));
  EXPECT_EQ(packed.data_encoding(), v1::GRID_ENCODING_ZSTD);
  EXPECT_LT(packed.data().size(), grid.data().size());
  httplib::Result refused = http().Get(path + "&format=png&dataEncoding=GRID_ENCODING_ZSTD");
  ASSERT_TRUE(refused);
  EXPECT_EQ(refused->status, 400);
  EXPECT_THAT(refused->body, HasSubstr("data_encoding"));
}

TEST_F(RestApiTest, HeightMapAsJsonAndAsA16BitPng) {
  const auto map = ParseJson<v1::HeightMap>(http().Get("/v1/maps/ycbv/heightMap"));
  ASSERT_GT(map.width(), 10u);
  ASSERT_EQ(map.heights_size(), int(map.width() * map.height()));
  httplib::Result r = http().Get("/v1/maps/ycbv/heightMap?format=png");
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200) << r->body;
  EXPECT_EQ(r->get_header_value("Content-Type"), "image/png");
  double offset = 0, scale = 0;
  ASSERT_TRUE(absl::SimpleAtod(r->get_header_value("X-Skimap-Z-Offset"), &offset));
  ASSERT_TRUE(absl::SimpleAtod(r->get_header_value("X-Skimap-Z-Scale"), &scale));
  EXPECT_DOUBLE_EQ(scale, 0.001);
  const cv::Mat image = ImDecode(r->body, ImageMode::kUnchanged);
  ASSERT_EQ(image.type(), CV_16UC1);
  ASSERT_EQ(image.cols, int(map.width()));
  ASSERT_EQ(image.rows, int(map.height()));
  int known = 0;
  for (int j = 0; j < int(map.height()); ++j) {
    for (int i = 0; i < int(map.width()); ++i) {
      const float z = map.heights(j * map.width() + i);
      const uint16_t v = image.at<uint16_t>(map.height() - 1 - j, i);
      if (std::isnan(z)) {
        EXPECT_EQ(v, 0);
      } else {
        ++known;
        EXPECT_NEAR(offset + v * scale, z, 0.0006);
      }
    }
  }
  EXPECT_GT(known, 100);
  // No PGM of a height map.
  EXPECT_THAT(ParseError(http().Get("/v1/maps/ycbv/heightMap?format=pgm"), 400).message(),
              HasSubstr("format"));
}

TEST_F(RestApiTest, VoxelPagesCoverTheMapOnceInKeyOrder) {
  v1::GetVoxelsRequest all;
  all.set_map("maps/ycbv");
  all.set_page_size(100000);
  auto expected = core().GetVoxels(all);
  ASSERT_TRUE(expected.ok());
  ASSERT_TRUE(expected->next_page_token().empty());
  std::vector<v1::Voxel> paged;
  std::string token;
  int pages = 0;
  do {
    std::string path = "/v1/maps/ycbv/voxels?pageSize=500";
    if (!token.empty())
      absl::StrAppend(&path, "&pageToken=", httplib::detail::encode_query_param(token));
    const auto page = ParseJson<v1::GetVoxelsResponse>(http().Get(path));
    ASSERT_LE(page.voxels_size(), 500);
    paged.insert(paged.end(), page.voxels().begin(), page.voxels().end());
    token = page.next_page_token();
    ASSERT_LT(++pages, 1000);
  } while (!token.empty());
  ASSERT_EQ(paged.size(), size_t(expected->voxels_size()));
  EXPECT_GT(pages, 1);
  for (size_t i = 0; i < paged.size(); ++i) {
    ASSERT_EQ(paged[i].SerializeAsString(), expected->voxels(int(i)).SerializeAsString()) << i;
  }

  // A box as one comma list or field by field: the same voxels as the core's box query.
  v1::GetVoxelsRequest boxed = all;
  boxed.mutable_box()->mutable_min()->set_x(-0.2);
  boxed.mutable_box()->mutable_min()->set_y(-0.2);
  boxed.mutable_box()->mutable_min()->set_z(-0.1);
  boxed.mutable_box()->mutable_max()->set_x(0.2);
  boxed.mutable_box()->mutable_max()->set_y(0.2);
  boxed.mutable_box()->mutable_max()->set_z(0.3);
  auto in_box = core().GetVoxels(boxed);
  ASSERT_TRUE(in_box.ok());
  EXPECT_GT(in_box->voxels_size(), 0);
  EXPECT_LT(in_box->voxels_size(), expected->voxels_size());
  for (const std::string& box :
       {std::string("box=-0.2,-0.2,-0.1,0.2,0.2,0.3"),
        std::string("box.min.x=-0.2&box.min.y=-0.2&box.min.z=-0.1&box.max.x=0.2&box.max.y=0.2"
                    "&box.max.z=0.3")}) {
    const auto page = ParseJson<v1::GetVoxelsResponse>(
        http().Get(absl::StrCat("/v1/maps/ycbv/voxels?pageSize=100000&", box)));
    EXPECT_EQ(page.voxels_size(), in_box->voxels_size()) << box;
  }
}

// Accept: application/x-protobuf answers the same message in the protobuf binary encoding
// (what the viewer reads), level of detail and page tokens included; JSON stays the default
// and errors stay JSON.
TEST_F(RestApiTest, VoxelPagesInTheProtobufBinaryEncodingAreTheCoresAnswer) {
  const httplib::Headers binary = {{"Accept", "application/x-protobuf"}};
  for (int level : {0, 2}) {
    v1::GetVoxelsRequest request;
    request.set_map("maps/ycbv");
    request.set_page_size(700);
    request.set_level(level);
    auto expected = core().GetVoxels(request);
    ASSERT_TRUE(expected.ok()) << expected.status();
    ASSERT_GT(expected->voxels_size(), 0);
    const std::string path = absl::StrCat("/v1/maps/ycbv/voxels?pageSize=700&level=", level);
    const auto answer = http().Get(path, binary);
    ASSERT_TRUE(answer);
    ASSERT_EQ(answer->status, 200) << answer->body;
    EXPECT_EQ(answer->get_header_value("Content-Type"), "application/x-protobuf");
    v1::GetVoxelsResponse page;
    ASSERT_TRUE(page.ParseFromString(answer->body)) << "level " << level;
    EXPECT_EQ(page.voxels_size(), expected->voxels_size()) << "level " << level;
    EXPECT_EQ(page.resolution(), expected->resolution());
    for (int i = 0; i < page.voxels_size(); ++i) {
      ASSERT_EQ(page.voxels(i).SerializeAsString(), expected->voxels(i).SerializeAsString()) << i;
    }
    // The next page by the binary answer's token is the core's next page.
    if (!page.next_page_token().empty()) {
      request.set_page_token(page.next_page_token());
      auto second = core().GetVoxels(request);
      ASSERT_TRUE(second.ok()) << second.status();
      const auto next = http().Get(
          absl::StrCat(path,
                       "&pageToken=", httplib::detail::encode_query_param(page.next_page_token())),
          binary);
      ASSERT_TRUE(next);
      v1::GetVoxelsResponse page2;
      ASSERT_TRUE(page2.ParseFromString(next->body));
      EXPECT_EQ(page2.voxels_size(), second->voxels_size());
    }
  }
  // Without the header: JSON. An error under the header: JSON naming the field.
  const auto json = http().Get("/v1/maps/ycbv/voxels?pageSize=5");
  ASSERT_TRUE(json);
  EXPECT_EQ(json->get_header_value("Content-Type"), "application/json");
  const auto bad = http().Get("/v1/maps/ycbv/voxels?level=9", binary);
  ASSERT_TRUE(bad);
  EXPECT_EQ(bad->status, 400);
  EXPECT_EQ(bad->get_header_value("Content-Type"), "application/json");
  EXPECT_NE(bad->body.find("level must be in 0..8"), std::string::npos) << bad->body;
}

TEST_F(RestApiTest, RadiusSearchAnswersTheCoresVoxels) {
  // Around a voxel of the map (the first in key order).
  v1::GetVoxelsRequest one;
  one.set_map("maps/ycbv");
  one.set_page_size(1);
  auto first = core().GetVoxels(one);
  ASSERT_TRUE(first.ok());
  ASSERT_EQ(first->voxels_size(), 1);
  v1::RadiusSearchRequest request;
  *request.mutable_center() = first->voxels(0).center();
  request.set_radius(0.1);
  const auto found = ParseJson<v1::RadiusSearchResponse>(
      http().Post("/v1/maps/ycbv:radiusSearch", ToJsonBody(request), kJson));
  request.set_map("maps/ycbv");
  auto expected = core().RadiusSearch(request);
  ASSERT_TRUE(expected.ok());
  EXPECT_GT(found.voxels_size(), 0);
  EXPECT_EQ(found.voxels_size(), expected->voxels_size());
  EXPECT_FALSE(found.truncated());
}

TEST_F(RestApiTest, UpdatePosesMovesAFrameAndBack) {
  ParseJson<v1::Map>(http().Post("/v1/maps", R"({"mapId": "loop"})", kJson));
  for (int i = 0; i < 2; ++i) {
    v1::Frame frame = frames_[i];
    frame.clear_map();  // the path names the map
    ParseJson<v1::FrameAck>(http().Post("/v1/maps/loop/frames", ToJsonBody(frame), kJson));
  }
  const uint64_t voxels = ParseJson<v1::Map>(http().Get("/v1/maps/loop")).stats().voxels();
  v1::UpdatePosesRequest moved;
  v1::PoseUpdate* update = moved.add_updates();
  update->set_sequence(1);
  *update->mutable_pose() = frames_[1].pose();
  update->mutable_pose()->mutable_translation()->set_z(frames_[1].pose().translation().z() + 0.5);
  const auto answer = ParseJson<v1::UpdatePosesResponse>(
      http().Post("/v1/maps/loop:updatePoses", ToJsonBody(moved), kJson));
  EXPECT_EQ(answer.frames_updated(), 1u);
  EXPECT_GT(answer.voxels_touched(), 0u);
  *update->mutable_pose() = frames_[1].pose();
  ParseJson<v1::UpdatePosesResponse>(
      http().Post("/v1/maps/loop:updatePoses", ToJsonBody(moved), kJson));
  EXPECT_EQ(ParseJson<v1::Map>(http().Get("/v1/maps/loop")).stats().voxels(), voxels);
  // An unknown frame: NotFound, nothing applied.
  update->set_sequence(7);
  EXPECT_THAT(
      ParseError(http().Post("/v1/maps/loop:updatePoses", ToJsonBody(moved), kJson), 404).message(),
      HasSubstr("7"));
}

TEST_F(RestApiTest, AFrameIsValidatedAsInTheStream) {
  v1::Frame frame = frames_[0];
  frame.set_sequence(100);
  frame.mutable_intrinsics()->set_fx(-1);
  const v1::RestError error =
      ParseError(http().Post("/v1/maps/ycbv/frames", ToJsonBody(frame), kJson), 400);
  EXPECT_EQ(error.status(), "INVALID_ARGUMENT");
  EXPECT_THAT(error.message(), HasSubstr("intrinsics.fx"));
  // A sequence already integrated: ALREADY_EXISTS, 409.
  EXPECT_EQ(
      ParseError(http().Post("/v1/maps/ycbv/frames", ToJsonBody(frames_[3]), kJson), 409).status(),
      "ALREADY_EXISTS");
  // The body's map must be the path's.
  EXPECT_THAT(ParseError(http().Post("/v1/maps/loop2/frames", ToJsonBody(frames_[0]), kJson), 400)
                  .message(),
              HasSubstr("map: the body names \"maps/ycbv\""));
}

TEST_F(RestApiTest, InstancesOfAMapWithoutRecognitionAreAPreconditionFailure) {
  const v1::RestError list = ParseError(http().Get("/v1/maps/ycbv/instances"), 409);
  EXPECT_EQ(list.status(), "FAILED_PRECONDITION");
  EXPECT_THAT(list.message(), HasSubstr("recognition"));
  EXPECT_EQ(ParseError(http().Get("/v1/maps/ycbv/instances/3"), 409).status(),
            "FAILED_PRECONDITION");
  EXPECT_EQ(ParseError(http().Get("/v1/maps/nope/instances"), 404).status(), "NOT_FOUND");
}

TEST_F(RestApiTest, ObjectsOfAnEmptyDatabase) {
  EXPECT_EQ(ParseJson<v1::ListObjectsResponse>(http().Get("/v1/objects")).objects_size(), 0);
  EXPECT_EQ(ParseError(http().Get("/v1/objects/5"), 404).status(), "NOT_FOUND");
}

// ---- Errors ----

TEST_F(RestApiTest, MalformedJsonIs400NamingTheField) {
  const v1::RestError type = ParseError(
      http().Post("/v1/maps", R"({"mapId": "x", "options": {"resolution": "fine"}})", kJson), 400);
  EXPECT_EQ(type.status(), "INVALID_ARGUMENT");
  EXPECT_THAT(type.message(), HasSubstr("body:"));
  EXPECT_THAT(type.message(), HasSubstr("resolution"));
  EXPECT_THAT(ParseError(http().Post("/v1/maps", R"({"mapId": "x", "resolutoin": 1})", kJson), 400)
                  .message(),
              HasSubstr("resolutoin"));
  EXPECT_THAT(ParseError(http().Post("/v1/maps", "{not json", kJson), 400).message(),
              HasSubstr("body:"));
  EXPECT_THAT(ParseError(http().Post("/v1/maps", "", kJson), 400).message(),
              HasSubstr("body: empty"));
  // Well-formed JSON that the core refuses: the core's message, naming the field.
  EXPECT_THAT(
      ParseError(http().Post("/v1/maps", R"({"mapId": "Kitchen 1"})", kJson), 400).message(),
      HasSubstr("map_id"));
  EXPECT_THAT(
      ParseError(http().Post("/v1/maps", R"({"mapId": "x", "options": {"resolution": 50}})", kJson),
                 400)
          .message(),
      HasSubstr("options.resolution"));
}

TEST_F(RestApiTest, MalformedQueryParametersAre400NamingTheParameter) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"/v1/maps/ycbv/voxels?pageSize=many", "query parameter pageSize: \"many\" is not"},
      {"/v1/maps/ycbv/voxels?box=1,2,3", "query parameter box: expected 6 comma-separated"},
      {"/v1/maps/ycbv/voxels?box=1,2,3,4,5,x", "query parameter box: max.z: \"x\" is not a number"},
      {"/v1/maps/ycbv/voxels?colour=red",
       "query parameter colour: unknown; this route takes box, "
       "pageSize, pageToken, minVoxelWeight"},
      {"/v1/maps/ycbv/voxels?map=maps/other", "query parameter map: unknown"},
      {"/v1/maps/ycbv/voxels?pageSize=1&pageSize=2", "query parameter pageSize: given 2 times"},
      {"/v1/maps/ycbv/voxels?pageToken=garbage", "page_token"},
      {"/v1/maps/ycbv/occupancyGrid?format=gif", "query parameter format: \"gif\""},
      {"/v1/maps/ycbv/occupancyGrid?region=0,0,1", "query parameter region: expected 4"},
      {"/v1/maps/ycbv/instances?objIds=1,two", "query parameter objIds: \"two\" is not"},
      {"/v1/maps/ycbv/instances?sphere=0,0,0", "query parameter sphere: expected 4"},
      {"/v1/objects/x1", "name"},
      {"/v1/objects/1?view=ALL", "query parameter view: \"ALL\" is not one of OBJECT_VIEW_"},
  };
  for (const auto& [path, message] : cases) {
    const v1::RestError error = ParseError(http().Get(path), 400);
    EXPECT_EQ(error.status(), "INVALID_ARGUMENT") << path;
    EXPECT_THAT(error.message(), HasSubstr(message)) << path;
  }
}

TEST_F(RestApiTest, UnknownMapsAndRoutesAre404) {
  for (const char* path : {"/v1/maps/nope", "/v1/maps/nope/occupancyGrid", "/v1/maps/nope/voxels",
                           "/v1/maps/nope/heightMap?format=png"}) {
    const v1::RestError error = ParseError(http().Get(path), 404);
    EXPECT_EQ(error.status(), "NOT_FOUND");
    EXPECT_THAT(error.message(), HasSubstr("maps/nope")) << path;
  }
  EXPECT_EQ(ParseError(http().Post("/v1/maps/nope:radiusSearch", R"({"radius": 1})", kJson), 404)
                .status(),
            "NOT_FOUND");
  for (const char* path : {"/", "/v2/maps", "/v1/maps/ycbv/grid", "/v1/maps/ycbv/voxels/extra"}) {
    const v1::RestError error = ParseError(http().Get(path), 404);
    EXPECT_EQ(error.status(), "NOT_FOUND");
    EXPECT_THAT(error.message(), HasSubstr("no route GET")) << path;
  }
}

TEST_F(RestApiTest, AKnownPathWithAnotherMethodIs405) {
  httplib::Result put = http().Put("/v1/maps", "{}", kJson);
  const v1::RestError error = ParseError(put, 405);
  EXPECT_THAT(error.message(), HasSubstr("it takes GET, POST"));
  EXPECT_EQ(put->get_header_value("Allow"), "GET, POST");
  EXPECT_EQ(ParseError(http().Get("/v1/maps/ycbv:radiusSearch"), 405).status(), "UNIMPLEMENTED");
  EXPECT_EQ(ParseError(http().Post("/v1/maps/ycbv", "{}", kJson), 405).code(), 405);
  EXPECT_EQ(ParseError(http().Delete("/v1/objects/1"), 405).code(), 405);
}

TEST_F(RestApiTest, ADuplicateCreateIs409) {
  const v1::RestError error =
      ParseError(http().Post("/v1/maps", R"({"mapId": "ycbv"})", kJson), 409);
  EXPECT_EQ(error.status(), "ALREADY_EXISTS");
  EXPECT_THAT(error.message(), HasSubstr("ycbv"));
}

TEST_F(RestApiTest, ABodyAboveTheLimitIs413) {
  const std::string big(5 << 20, ' ');  // the suite's server takes 4 MiB
  const v1::RestError error = ParseError(http().Post("/v1/maps", big, kJson), 413);
  EXPECT_EQ(error.status(), "RESOURCE_EXHAUSTED");
  EXPECT_THAT(error.message(), HasSubstr("--http_max_body_mb"));
  // The server goes on.
  EXPECT_EQ(ParseJson<v1::HealthzResponse>(http().Get("/healthz")).status(), "SERVING");
}

TEST(RestCorsTest, PreflightsFromAllowedOriginsPassAndOthersAreRefused) {
  RestServer rest({.cors_origins = {"https://viewer.example"}});
  httplib::Headers allowed = {{"Origin", "https://viewer.example"},
                              {"Access-Control-Request-Method", "POST"},
                              {"Access-Control-Request-Headers", "content-type"}};
  httplib::Result ok = rest.http().Options("/v1/maps", allowed);
  ASSERT_TRUE(ok);
  EXPECT_EQ(ok->status, 204);
  EXPECT_EQ(ok->get_header_value("Access-Control-Allow-Origin"), "https://viewer.example");
  EXPECT_EQ(ok->get_header_value("Access-Control-Allow-Methods"), "GET, POST");
  EXPECT_EQ(ok->get_header_value("Access-Control-Allow-Headers"), "content-type");

  httplib::Headers other = {{"Origin", "https://evil.example"},
                            {"Access-Control-Request-Method", "DELETE"}};
  httplib::Result denied = rest.http().Options("/v1/maps/x", other);
  const v1::RestError error = ParseError(denied, 403);
  EXPECT_EQ(error.status(), "PERMISSION_DENIED");
  EXPECT_THAT(error.message(), HasSubstr("--http_cors_origins"));
  EXPECT_FALSE(denied->has_header("Access-Control-Allow-Origin"));

  // Simple requests: the allowed origin may read the answer, the other gets no CORS header
  // (its browser hides the answer); clients without Origin are not affected.
  httplib::Result read = rest.http().Get("/v1/maps", {{"Origin", "https://viewer.example"}});
  ParseJson<v1::ListMapsResponse>(read);
  EXPECT_EQ(read->get_header_value("Access-Control-Allow-Origin"), "https://viewer.example");
  EXPECT_THAT(read->get_header_value("Access-Control-Expose-Headers"),
              HasSubstr("X-Skimap-Resolution"));
  httplib::Result foreign = rest.http().Get("/v1/maps", {{"Origin", "https://evil.example"}});
  ParseJson<v1::ListMapsResponse>(foreign);
  EXPECT_FALSE(foreign->has_header("Access-Control-Allow-Origin"));
  // A preflight for a path no route has.
  ParseError(rest.http().Options("/v1/nothing", allowed), 404);
}

TEST(RestCorsTest, NoOriginIsAllowedByDefault) {
  RestServer rest;
  ParseError(rest.http().Options("/v1/maps", {{"Origin", "https://viewer.example"},
                                              {"Access-Control-Request-Method", "GET"}}),
             403);
}

}  // namespace
}  // namespace skimap::testing
