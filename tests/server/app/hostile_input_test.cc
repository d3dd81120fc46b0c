// Hostile input against a real skimapd process: every class of bad frame or query gets a
// clear status naming the field, and afterwards the process is alive, healthy and its map
// unchanged. (Each of these once took the whole server down or misbehaved; issue 9.)
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <opencv2/core.hpp>
#include <set>
#include <tuple>

#include "client/map_client.h"
#include "tests/common/images.h"
#include "tests/common/skimapd_process.h"
#include "tests/common/synthetic_scene.h"

namespace skimap::testing {
namespace {

using ::testing::HasSubstr;
using Code = absl::StatusCode;

uint32_t Crc32(const uint8_t* p, size_t n) {  // PNG's CRC (ISO 3309), bit by bit
  uint32_t c = 0xffffffffu;
  for (size_t i = 0; i < n; ++i) {
    c ^= p[i];
    for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0xedb88320u & (0u - (c & 1)));
  }
  return c ^ 0xffffffffu;
}

void PutBe(std::string* s, size_t at, uint32_t v, int bytes) {
  for (int i = 0; i < bytes; ++i) (*s)[at + i] = char(v >> (8 * (bytes - 1 - i)));
}

std::string Encode(const char* ext, const cv::Mat& m) {
  std::vector<uint8_t> buf;
  EXPECT_TRUE(ImEncode(ext, m, &buf));
  return std::string(buf.begin(), buf.end());
}

// A real PNG whose IHDR (CRC resealed) claims width x height: a decoder that trusts it
// sizes its buffers from it.
std::string PngClaiming(const cv::Mat& m, uint32_t width, uint32_t height) {
  std::string png = Encode(".png", m);
  PutBe(&png, 16, width, 4);
  PutBe(&png, 20, height, 4);
  PutBe(&png, 29, Crc32(reinterpret_cast<const uint8_t*>(png.data()) + 12, 17), 4);
  return png;
}

// A real JPEG whose SOF0 claims width x height.
std::string JpegClaiming(const cv::Mat& m, uint16_t width, uint16_t height) {
  std::string jpg = Encode(".jpg", m);
  const size_t sof = jpg.find("\xff\xc0");
  EXPECT_NE(sof, std::string::npos);
  PutBe(&jpg, sof + 5, height, 2);
  PutBe(&jpg, sof + 7, width, 2);
  return jpg;
}

class HostileInputTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(server_.Start().ok());
    client_ = client::MapClient::Connect(server_.address());
    v1::CreateMapRequest create;
    create.set_map_id("target");
    ASSERT_TRUE(client_->CreateMap(create).ok());
    good_ = MakeFrame("maps/target", 0, DefaultView());
    auto ack = client_->IntegrateFrame(good_);
    ASSERT_TRUE(ack.ok()) << ack.status();
    before_ = Voxels("maps/target");
    ASSERT_GT(before_.size(), 100u);
  }

  // Every voxel of `map` as (centre, weight) tuples, via StreamVoxels.
  std::set<std::tuple<double, double, double, float>> Voxels(const std::string& map) {
    v1::GetVoxelsRequest request;
    request.set_map(map);
    auto voxels = client_->GetAllVoxels(request);
    EXPECT_TRUE(voxels.ok()) << voxels.status();
    std::set<std::tuple<double, double, double, float>> out;
    for (const v1::Voxel& v : voxels.value_or(std::vector<v1::Voxel>{})) {
      out.insert({v.center().x(), v.center().y(), v.center().z(), v.weight()});
    }
    return out;
  }

  // The frame sent unary and on a stream: the same code and field both ways.
  void ExpectRefused(const v1::Frame& frame, Code code, const std::string& field) {
    absl::StatusOr<v1::FrameAck> unary = client_->IntegrateFrame(frame);
    EXPECT_EQ(unary.status().code(), code) << unary.status();
    EXPECT_THAT(unary.status().message(), HasSubstr(field));
    std::unique_ptr<client::FrameStream> stream = client_->OpenFrameStream({.window = 2});
    ASSERT_TRUE(stream->Send(frame).ok());
    absl::StatusOr<std::vector<v1::FrameAck>> acks = stream->Finish();
    ASSERT_TRUE(acks.ok()) << acks.status();
    ASSERT_EQ(acks->size(), 1u);
    EXPECT_EQ((*acks)[0].code(), int(code)) << (*acks)[0].message();
    EXPECT_THAT((*acks)[0].message(), HasSubstr(field));
  }

  // The server survived, still serves, and the map holds exactly what it held.
  void ExpectHealthyAndUnchanged() {
    ASSERT_TRUE(server_.Running()) << "skimapd died";
    EXPECT_EQ(Voxels("maps/target"), before_);
    v1::Frame next = good_;
    next.set_sequence(next_sequence_++);
    auto ack = client_->IntegrateFrame(next);
    EXPECT_TRUE(ack.ok()) << ack.status();
    EXPECT_GT(ack->points(), 0u);
    before_ = Voxels("maps/target");
  }

  SkimapdProcess server_{SKIMAPD_PATH, {"--worker_threads=1", "--max_message_mb=16"}};
  std::unique_ptr<client::MapClient> client_;
  v1::Frame good_;
  uint64_t next_sequence_ = 1000;
  std::set<std::tuple<double, double, double, float>> before_;
};

TEST_F(HostileInputTest, ImagesClaimingHugeDimensionsAreRefusedBeforeDecoding) {
  const cv::Mat depth16(8, 8, CV_16UC1, cv::Scalar(1000)), rgb(8, 8, CV_8UC3, cv::Scalar(1, 2, 3));
  uint64_t sequence = 1;
  auto frame = [&] {
    v1::Frame f = good_;
    f.set_sequence(sequence++);
    return f;
  };
  for (auto [w, h] : {std::pair<uint32_t, uint32_t>{100000, 100000}, {65000, 65000}}) {
    v1::Frame depth = frame();
    depth.set_depth_encoding(v1::DEPTH_ENCODING_PNG16);
    depth.set_depth(PngClaiming(depth16, w, h));
    ExpectRefused(depth, Code::kInvalidArgument, "depth: image header claims");
    v1::Frame png = frame();
    png.set_color_encoding(v1::COLOR_ENCODING_PNG);
    png.set_color(PngClaiming(rgb, w, h));
    ExpectRefused(png, Code::kInvalidArgument, "color: image header claims");
  }
  v1::Frame jpeg = frame();
  jpeg.set_color_encoding(v1::COLOR_ENCODING_JPEG);
  jpeg.set_color(JpegClaiming(rgb, 65000, 65000));
  ExpectRefused(jpeg, Code::kInvalidArgument, "color: image header claims");
  ExpectHealthyAndUnchanged();
}

TEST_F(HostileInputTest, TruncatedJpegAndSixteenBitColourAreRefused) {
  const cv::Mat rgb(120, 160, CV_8UC3, cv::Scalar(10, 20, 30));
  v1::Frame truncated = good_;
  truncated.set_sequence(1);
  truncated.set_color_encoding(v1::COLOR_ENCODING_JPEG);
  const std::string jpeg = Encode(".jpg", rgb);
  truncated.set_color(jpeg.substr(0, jpeg.size() * 2 / 3));
  ExpectRefused(truncated, Code::kInvalidArgument, "color: not a JPEG (no EOI marker");
  v1::Frame deep = good_;
  deep.set_sequence(2);
  deep.set_color_encoding(v1::COLOR_ENCODING_PNG);
  deep.set_color(Encode(".png", cv::Mat(120, 160, CV_16UC3, cv::Scalar(1000, 2000, 3000))));
  ExpectRefused(deep, Code::kInvalidArgument, "color: PNG has 16-bit samples");
  v1::Frame eight_bit_depth = good_;
  eight_bit_depth.set_sequence(3);
  eight_bit_depth.set_depth_encoding(v1::DEPTH_ENCODING_PNG16);
  eight_bit_depth.set_depth(Encode(".png", cv::Mat(120, 160, CV_8UC1, cv::Scalar(7))));
  ExpectRefused(eight_bit_depth, Code::kInvalidArgument, "depth: PNG must be 16-bit greyscale");
  ExpectHealthyAndUnchanged();
}

TEST_F(HostileInputTest, ImplausibleCamerasAndPosesAreRefusedNamingTheField) {
  struct Case {
    const char* field;
    std::function<void(v1::Frame&)> mutate;
  };
  const std::vector<Case> cases = {
      {"intrinsics.cx", [](v1::Frame& f) { f.mutable_intrinsics()->set_cx(1e6); }},
      {"intrinsics.cy", [](v1::Frame& f) { f.mutable_intrinsics()->set_cy(-1e6); }},
      {"intrinsics.fx: horizontal field of view",
       [](v1::Frame& f) { f.mutable_intrinsics()->set_fx(1e-3); }},
      {"intrinsics.fy: vertical field of view",
       [](v1::Frame& f) { f.mutable_intrinsics()->set_fy(1e7); }},
      {"pose.translation",
       [](v1::Frame& f) { f.mutable_pose()->mutable_translation()->set_x(1e9); }},
      {"pose.translation",
       [](v1::Frame& f) { f.mutable_pose()->mutable_translation()->set_z(-1e5); }},
  };
  uint64_t sequence = 1;
  for (const Case& c : cases) {
    SCOPED_TRACE(c.field);
    v1::Frame f = good_;
    f.set_sequence(sequence++);
    c.mutate(f);
    ExpectRefused(f, Code::kInvalidArgument, c.field);
  }
  ExpectHealthyAndUnchanged();
  // The map's bounds still describe the scene, so a whole-map grid still fits in a reply.
  v1::GetOccupancyGridRequest grid;
  grid.set_map("maps/target");
  auto answer = client_->GetOccupancyGrid(grid);
  ASSERT_TRUE(answer.ok()) << answer.status();
  EXPECT_LT(answer->width() * answer->resolution(), 10.0);
}

TEST_F(HostileInputTest, AnOkAckThatIntegratedNothingSaysSo) {
  v1::Frame far = good_;
  far.set_sequence(1);
  far.set_depth_scale(1.0);  // every pixel now reads hundreds of metres: beyond max_depth
  auto ack = client_->IntegrateFrame(far);
  ASSERT_TRUE(ack.ok()) << ack.status();
  EXPECT_EQ(ack->points(), 0u);
  EXPECT_GT(ack->points_out_of_range(), 1000u);
  EXPECT_THAT(ack->message(), HasSubstr("integrated nothing"));
  v1::Frame normal = good_;
  normal.set_sequence(2);
  ack = client_->IntegrateFrame(normal);
  ASSERT_TRUE(ack.ok());
  EXPECT_TRUE(ack->message().empty()) << ack->message();
  EXPECT_EQ(ack->points_out_of_range(), 0u);
}

TEST_F(HostileInputTest, RastersThatCannotFitInAReplyAreRefusedBeforeTheyAreBuilt) {
  v1::CreateMapRequest create;
  create.set_map_id("fine");
  create.mutable_options()->set_resolution(0.01);
  ASSERT_TRUE(client_->CreateMap(create).ok());
  v1::Frame f = good_;
  f.set_map("maps/fine");
  ASSERT_TRUE(client_->IntegrateFrame(f).ok());
  const size_t peak_before = server_.PeakRssBytes();
  // 150 m x 150 m at 1 cm: 2.25e8 cells, under the raster cap (2^28) but 225 MB as a grid
  // and 900 MB as a height map, far above the 16 MiB reply limit.
  v1::Region2D region;
  region.set_min_x(-75);
  region.set_min_y(-75);
  region.set_max_x(75);
  region.set_max_y(75);
  v1::GetOccupancyGridRequest grid;
  grid.set_map("maps/fine");
  *grid.mutable_region() = region;
  auto g = client_->GetOccupancyGrid(grid);
  EXPECT_EQ(g.status().code(), Code::kResourceExhausted);
  EXPECT_THAT(g.status().message(), HasSubstr("max_reply_bytes"));
  EXPECT_THAT(g.status().message(), HasSubstr("region"));
  v1::GetHeightMapRequest height;
  height.set_map("maps/fine");
  *height.mutable_region() = region;
  auto h = client_->GetHeightMap(height);
  EXPECT_EQ(h.status().code(), Code::kResourceExhausted);
  EXPECT_THAT(h.status().message(), HasSubstr("max_reply_bytes"));
  // Refused up front: the server's peak memory did not grow by the raster's size.
  EXPECT_LT(server_.PeakRssBytes(), peak_before + (64 << 20));
  // A region that fits is still served.
  region.set_min_x(-2);
  region.set_min_y(-2);
  region.set_max_x(2);
  region.set_max_y(2);
  *grid.mutable_region() = region;
  EXPECT_TRUE(client_->GetOccupancyGrid(grid).ok());
  ExpectHealthyAndUnchanged();
}

TEST_F(HostileInputTest, LongClientStringsAreEchoedCapped) {
  const std::string huge(100000, 'a');
  v1::CreateMapRequest create;
  create.set_map_id(huge);
  auto created = client_->CreateMap(create);
  EXPECT_EQ(created.status().code(), Code::kInvalidArgument) << created.status().code();
  EXPECT_THAT(created.status().message(), HasSubstr("map_id"));
  EXPECT_THAT(created.status().message(), HasSubstr("(+99936 bytes)"));
  EXPECT_LT(created.status().message().size(), 300u);
  auto got = client_->GetMap("maps/" + huge);
  EXPECT_EQ(got.status().code(), Code::kInvalidArgument);
  EXPECT_LT(got.status().message().size(), 300u);
  v1::Frame f = good_;
  f.set_map("maps/" + huge);
  ExpectRefused(f, Code::kInvalidArgument, "map must be");
  ExpectHealthyAndUnchanged();
}

TEST_F(HostileInputTest, PageTokensAreBoundToTheirMapAndQuery) {
  v1::CreateMapRequest create;
  create.set_map_id("other");
  ASSERT_TRUE(client_->CreateMap(create).ok());
  v1::Frame f = good_;
  f.set_map("maps/other");
  ASSERT_TRUE(client_->IntegrateFrame(f).ok());
  v1::GetVoxelsRequest request;
  request.set_map("maps/target");
  request.set_page_size(10);
  auto first = client_->GetVoxels(request);
  ASSERT_TRUE(first.ok()) << first.status();
  const std::string token = first->next_page_token();
  ASSERT_FALSE(token.empty());
  auto refused = [&](v1::GetVoxelsRequest r) {
    auto page = client_->GetVoxels(r);
    EXPECT_EQ(page.status().code(), Code::kInvalidArgument);
    EXPECT_THAT(page.status().message(), HasSubstr("page_token"));
  };
  v1::GetVoxelsRequest r = request;
  r.set_page_token(token.substr(0, token.size() - 3));
  refused(r);  // truncated
  r.set_page_token(std::string(1, token[0] == 'A' ? 'B' : 'A') + token.substr(1));
  refused(r);  // altered
  r.set_page_token("garbage!");
  refused(r);
  r = request;
  r.set_map("maps/other");
  r.set_page_token(token);
  refused(r);  // another map
  r = request;
  r.mutable_box()->mutable_max()->set_x(1);
  r.mutable_box()->mutable_max()->set_y(1);
  r.mutable_box()->mutable_max()->set_z(1);
  r.set_page_token(token);
  refused(r);  // another box
  r = request;
  r.set_min_voxel_weight(2);
  r.set_page_token(token);
  refused(r);  // another filter
  // The same id deleted and created again is another map.
  ASSERT_TRUE(client_->DeleteMap("maps/other").ok());
  ASSERT_TRUE(client_->CreateMap(create).ok());
  v1::GetVoxelsRequest other = request;
  other.set_map("maps/other");
  // (the new map is empty: no page 2 exists, but its token check comes first)
  other.set_page_token(token);
  refused(other);
  // Paging with the right tokens visits every voxel exactly once, page size changing.
  size_t total = 0;
  r = request;
  for (int page = 0;; ++page) {
    r.set_page_size(page % 2 ? 37 : 500);
    auto p = client_->GetVoxels(r);
    ASSERT_TRUE(p.ok()) << p.status();
    total += p->voxels_size();
    if (p->next_page_token().empty()) break;
    r.set_page_token(p->next_page_token());
  }
  EXPECT_EQ(total, before_.size());
  // ListMaps tokens are opaque too.
  v1::ListMapsRequest list;
  list.set_page_size(1);
  auto maps = client_->ListMaps(list);
  ASSERT_TRUE(maps.ok());
  ASSERT_FALSE(maps->next_page_token().empty());
  list.set_page_token(maps->next_page_token() + "x");
  EXPECT_EQ(client_->ListMaps(list).status().code(), Code::kInvalidArgument);
  ExpectHealthyAndUnchanged();
}

TEST_F(HostileInputTest, QueriesRefuseWhatCreateMapRefusesForMinVoxelWeight) {
  for (float bad :
       {std::numeric_limits<float>::quiet_NaN(), -1.0f, std::numeric_limits<float>::infinity()}) {
    SCOPED_TRACE(bad);
    v1::GetOccupancyGridRequest grid;
    grid.set_map("maps/target");
    grid.set_min_voxel_weight(bad);
    EXPECT_EQ(client_->GetOccupancyGrid(grid).status().code(), Code::kInvalidArgument);
    EXPECT_THAT(client_->GetOccupancyGrid(grid).status().message(), HasSubstr("min_voxel_weight"));
    v1::GetHeightMapRequest height;
    height.set_map("maps/target");
    height.set_min_voxel_weight(bad);
    EXPECT_EQ(client_->GetHeightMap(height).status().code(), Code::kInvalidArgument);
    v1::GetVoxelsRequest voxels;
    voxels.set_map("maps/target");
    voxels.set_min_voxel_weight(bad);
    EXPECT_EQ(client_->GetVoxels(voxels).status().code(), Code::kInvalidArgument);
    v1::RadiusSearchRequest radius;
    radius.set_map("maps/target");
    radius.set_radius(1);
    radius.set_min_voxel_weight(bad);
    EXPECT_EQ(client_->RadiusSearch(radius).status().code(), Code::kInvalidArgument);
  }
  ExpectHealthyAndUnchanged();
}

}  // namespace
}  // namespace skimap::testing
