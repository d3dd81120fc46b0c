// Server limits through a real skimapd process: each answers RESOURCE_EXHAUSTED with a
// message naming the limit and its flag, and nothing else breaks (the stream, the other
// maps and the server go on).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "client/frame_stream.h"
#include "server/grpc/stream_limiter.h"
#include "tests/common/skimapd_process.h"

namespace skimap::testing {
namespace {

using ::testing::HasSubstr;

// A width x height frame of a wall 1 m ahead (raw depth, no colour), camera at x = shift.
v1::Frame Wall(const std::string& map, uint64_t sequence, int width = 32, int height = 24,
               double shift = 0) {
  v1::Frame f;
  f.set_map(map);
  f.set_sequence(sequence);
  f.mutable_pose()->mutable_rotation()->set_w(1);
  f.mutable_pose()->mutable_translation()->set_x(shift);
  v1::CameraIntrinsics& k = *f.mutable_intrinsics();
  k.set_width(width);
  k.set_height(height);
  k.set_fx(width);
  k.set_fy(width);
  k.set_cx(width / 2.0);
  k.set_cy(height / 2.0);
  f.set_depth_encoding(v1::DEPTH_ENCODING_RAW_U16);
  std::string depth(size_t(width) * height * 2, '\0');
  for (size_t i = 0; i < depth.size(); i += 2) {
    depth[i] = static_cast<char>(1000 & 0xff);
    depth[i + 1] = static_cast<char>(1000 >> 8);
  }
  f.set_depth(depth);
  f.set_depth_scale(0.001);
  return f;
}

v1::CreateMapRequest Create(const std::string& id, double resolution = 0.01) {
  v1::CreateMapRequest r;
  r.set_map_id(id);
  r.mutable_options()->set_resolution(resolution);
  return r;
}

uint64_t VoxelCount(client::MapClient& client, const std::string& map) {
  absl::StatusOr<v1::Map> m = client.GetMap(map);
  return m.ok() ? m->stats().voxels() : 0;
}

TEST(LimitsTest, MapsPerServerNamesTheLimitAndItsFlag) {
  SkimapdProcess server(SKIMAPD_PATH, {"--max_maps=2"});
  ASSERT_TRUE(server.Start().ok());
  auto client = client::MapClient::Connect(server.address());
  ASSERT_TRUE(client->CreateMap(Create("a")).ok());
  ASSERT_TRUE(client->CreateMap(Create("b")).ok());
  absl::StatusOr<v1::Map> third = client->CreateMap(Create("c"));
  ASSERT_EQ(third.status().code(), absl::StatusCode::kResourceExhausted) << third.status();
  EXPECT_THAT(third.status().message(), HasSubstr("limit is 2 maps per server"));
  EXPECT_THAT(third.status().message(), HasSubstr("--max_maps"));
  // Room again once a map is gone; the others were untouched.
  ASSERT_TRUE(client->DeleteMap("maps/a").ok());
  EXPECT_TRUE(client->CreateMap(Create("c")).ok());
  EXPECT_TRUE(client->GetMap("maps/b").ok());
  EXPECT_TRUE(server.Running());
}

TEST(LimitsTest, VoxelsPerMapRefuseFurtherFramesAndTheStreamGoesOn) {
  // A 32 x 24 wall at 1 cm gives 768 voxels: the first frame starts under 500 and is
  // integrated whole; the next is refused, on that map only.
  SkimapdProcess server(SKIMAPD_PATH, {"--max_map_voxels=500"});
  ASSERT_TRUE(server.Start().ok());
  auto client = client::MapClient::Connect(server.address());
  ASSERT_TRUE(client->CreateMap(Create("full")).ok());
  ASSERT_TRUE(client->CreateMap(Create("other")).ok());
  std::unique_ptr<client::FrameStream> stream = client->OpenFrameStream({.window = 1});
  ASSERT_TRUE(stream->Send(Wall("maps/full", 0)).ok());
  ASSERT_TRUE(stream->Send(Wall("maps/full", 1, 32, 24, 0.5)).ok());
  ASSERT_TRUE(stream->Send(Wall("maps/other", 0)).ok());
  absl::StatusOr<std::vector<v1::FrameAck>> acks = stream->Finish();
  ASSERT_TRUE(acks.ok()) << acks.status();
  ASSERT_EQ(acks->size(), 3u);
  EXPECT_EQ((*acks)[0].code(), 0) << (*acks)[0].message();
  EXPECT_EQ((*acks)[1].code(), int(absl::StatusCode::kResourceExhausted));
  EXPECT_THAT((*acks)[1].message(), HasSubstr("the limit is 500 per map"));
  EXPECT_THAT((*acks)[1].message(), HasSubstr("--max_map_voxels"));
  EXPECT_EQ((*acks)[2].code(), 0) << (*acks)[2].message();
  const uint64_t full = VoxelCount(*client, "maps/full");
  EXPECT_GE(full, 500u);
  EXPECT_EQ(client->GetMap("maps/full")->stats().frames(), 1u);
  EXPECT_EQ(VoxelCount(*client, "maps/other"), full);  // the same wall
  EXPECT_TRUE(server.Running());
}

TEST(LimitsTest, FramePixelsAndBytesNameTheirFlags) {
  SkimapdProcess server(SKIMAPD_PATH, {"--max_frame_pixels=1000", "--max_message_mb=1"});
  ASSERT_TRUE(server.Start().ok());
  auto client = client::MapClient::Connect(server.address());
  ASSERT_TRUE(client->CreateMap(Create("m")).ok());
  absl::StatusOr<v1::FrameAck> wide = client->IntegrateFrame(Wall("maps/m", 0, 40, 30));
  ASSERT_EQ(wide.status().code(), absl::StatusCode::kResourceExhausted) << wide.status();
  EXPECT_THAT(wide.status().message(), HasSubstr("40 x 30 pixels exceed the limit of 1000"));
  EXPECT_THAT(wide.status().message(), HasSubstr("--max_frame_pixels"));
  // 900 KB of images: under the 1 MiB message limit, over the 80 % frames may take.
  v1::Frame heavy = Wall("maps/m", 1);
  heavy.set_color_encoding(v1::COLOR_ENCODING_RAW_RGB8);
  heavy.set_color(std::string(900000, 'x'));
  absl::StatusOr<v1::FrameAck> big = client->IntegrateFrame(heavy);
  ASSERT_EQ(big.status().code(), absl::StatusCode::kResourceExhausted) << big.status();
  EXPECT_THAT(big.status().message(), HasSubstr("--max_message_mb"));
  // The map took neither and takes a frame within the limits.
  EXPECT_TRUE(client->IntegrateFrame(Wall("maps/m", 2)).ok());
  EXPECT_EQ(client->GetMap("maps/m")->stats().frames(), 1u);
}

TEST(LimitsTest, StreamsPerClientNameTheLimitAndFreeWhenAStreamEnds) {
  SkimapdProcess server(SKIMAPD_PATH, {"--max_streams_per_client=2"});
  ASSERT_TRUE(server.Start().ok());
  auto client = client::MapClient::Connect(server.address());
  ASSERT_TRUE(client->CreateMap(Create("m")).ok());
  // Two open streams, each with an acknowledged frame (so both calls are established).
  std::vector<std::unique_ptr<client::FrameStream>> open;
  for (uint64_t i = 0; i < 2; ++i) {
    open.push_back(client->OpenFrameStream({.window = 1}));
    ASSERT_TRUE(open.back()->Send(Wall("maps/m", i, 32, 24, 0.1 * double(i))).ok());
    ASSERT_TRUE(open.back()->Send(Wall("maps/m", 10 + i, 32, 24, 0.1 * double(i))).ok());
  }
  auto third = client->OpenFrameStream({.window = 1});
  (void)third->Send(Wall("maps/m", 20));  // may fail already: the call is refused
  absl::StatusOr<std::vector<v1::FrameAck>> refused = third->Finish();
  ASSERT_EQ(refused.status().code(), absl::StatusCode::kResourceExhausted) << refused.status();
  EXPECT_THAT(refused.status().message(), HasSubstr("the limit is 2 per client"));
  EXPECT_THAT(refused.status().message(), HasSubstr("--max_streams_per_client"));
  // The open streams go on; once one ends, a new stream is accepted.
  ASSERT_TRUE(open[0]->Finish().ok());
  auto again = client->OpenFrameStream({.window = 1});
  ASSERT_TRUE(again->Send(Wall("maps/m", 30, 32, 24, 0.3)).ok());
  absl::StatusOr<std::vector<v1::FrameAck>> acks = again->Finish();
  ASSERT_TRUE(acks.ok()) << acks.status();
  ASSERT_EQ(acks->size(), 1u);
  EXPECT_EQ((*acks)[0].code(), 0) << (*acks)[0].message();
  ASSERT_TRUE(open[1]->Finish().ok());
  EXPECT_EQ(client->GetMap("maps/m")->stats().frames(), 5u);
}

TEST(StreamLimiterTest, ClientIsThePeerAddressWithoutItsPort) {
  EXPECT_EQ(server::StreamLimiter::ClientOf("ipv4:127.0.0.1:5555"), "ipv4:127.0.0.1");
  EXPECT_EQ(server::StreamLimiter::ClientOf("ipv6:[::1]:5555"), "ipv6:[::1]");
  EXPECT_EQ(server::StreamLimiter::ClientOf("unix:/tmp/s"), "unix:/tmp/s");
  server::StreamLimiter limiter(1);
  absl::StatusOr<server::StreamLimiter::Slot> a = limiter.Acquire("ipv4:10.0.0.1:1");
  ASSERT_TRUE(a.ok());
  EXPECT_FALSE(limiter.Acquire("ipv4:10.0.0.1:2").ok());
  EXPECT_TRUE(limiter.Acquire("ipv4:10.0.0.2:1").ok());
  *a = server::StreamLimiter::Slot();
  EXPECT_EQ(limiter.Open("ipv4:10.0.0.1:9"), 0);
  EXPECT_TRUE(limiter.Acquire("ipv4:10.0.0.1:3").ok());
}

}  // namespace
}  // namespace skimap::testing
