// GET /metrics against the real skimapd: frames streamed over gRPC, REST calls, then the
// exposition parsed and compared with what was sent and answered.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <httplib.h>

#include <string>

#include "tests/common/skimapd_process.h"
#include "tests/server/app/test_frames.h"

namespace skimap::testing {
namespace {

TEST(MetricsTest, ScrapeCountsTheFramesAndCallsThatWereSent) {
  SkimapdProcess server(SKIMAPD_PATH, {"--worker_threads=1", "--max_frame_pixels=5000"});
  ASSERT_TRUE(server.Start().ok());
  auto stub = MapStub(server.address());
  {
    grpc::ClientContext ctx;
    v1::CreateMapRequest create;
    create.set_map_id("m");
    v1::Map map;
    ASSERT_TRUE(stub->CreateMap(&ctx, create, &map).ok());
  }
  // 6 frames of new space, one above --max_frame_pixels, one whose depth does not match
  // its size; one stream.
  int acked = 0;
  std::map<int, int> refused_codes;
  {
    grpc::ClientContext ctx;
    auto stream = stub->StreamFrames(&ctx);
    for (uint64_t seq = 0; seq < 6; ++seq) ASSERT_TRUE(stream->Write(WallFrame("maps/m", seq)));
    ASSERT_TRUE(stream->Write(WallFrame("maps/m", 6, /*width=*/400)));  // 9600 pixels
    ASSERT_TRUE(stream->Write(WallFrame("maps/m", 7, /*width=*/40)));   // depth too short
    stream->WritesDone();
    v1::FrameAck ack;
    while (stream->Read(&ack)) {
      if (ack.code() == 0) {
        ++acked;
      } else {
        ++refused_codes[ack.code()];
      }
    }
    ASSERT_TRUE(stream->Finish().ok());
  }
  EXPECT_EQ(acked, 6);
  EXPECT_EQ(refused_codes[grpc::RESOURCE_EXHAUSTED], 1);
  EXPECT_EQ(refused_codes[grpc::INVALID_ARGUMENT], 1);

  httplib::Client http("127.0.0.1", server.http_port());
  ASSERT_EQ(http.Get("/v1/maps/m")->status, 200);
  ASSERT_EQ(http.Get("/v1/maps/nope")->status, 404);
  ASSERT_EQ(
      http.Post("/v1/maps/m:radiusSearch",
                R"({"center": {"x": 0.1, "y": 0, "z": 1}, "radius": 0.2})", "application/json")
          ->status,
      200);

  httplib::Result scrape = http.Get("/metrics");
  ASSERT_TRUE(scrape);
  ASSERT_EQ(scrape->status, 200);
  EXPECT_THAT(scrape->get_header_value("Content-Type"), ::testing::StartsWith("text/plain"));
  const std::vector<Sample> m = ParseExposition(scrape->body);

  EXPECT_EQ(SampleValue(m, "skimap_frames_ingested_total"), acked);
  EXPECT_EQ(SampleValue(m, "skimap_frames_refused_total", {{"reason", "max_frame_pixels"}}), 1);
  EXPECT_EQ(SampleValue(m, "skimap_frames_refused_total", {{"reason", "INVALID_ARGUMENT"}}), 1);
  // Integrated and journaled: the acknowledged frames only.
  EXPECT_EQ(SampleValue(m, "skimap_integration_seconds_count"), acked);
  // One append per group of frames queued behind each other (group commit): at least one,
  // at most one per acknowledged frame.
  EXPECT_GE(SampleValue(m, "skimap_journal_append_seconds_count"), 1);
  EXPECT_LE(SampleValue(m, "skimap_journal_append_seconds_count"), acked);
  EXPECT_GT(SampleValue(m, "skimap_map_voxels", {{"map", "maps/m"}}), 0);
  EXPECT_GT(SampleValue(m, "skimap_map_memory_bytes", {{"map", "maps/m"}}), 0);
  EXPECT_EQ(SampleValue(m, "skimap_map_queued_writes", {{"map", "maps/m"}}), 0);
  EXPECT_EQ(SampleValue(m, "skimap_map_instances", {{"map", "maps/m"}}), 0);

  EXPECT_EQ(SampleValue(m, "skimap_grpc_request_seconds_count",
                        {{"method", "skimap.v1.MapService/CreateMap"}, {"code", "OK"}}),
            1);
  EXPECT_EQ(SampleValue(m, "skimap_grpc_request_seconds_count",
                        {{"method", "skimap.v1.MapService/StreamFrames"}, {"code", "OK"}}),
            1);
  EXPECT_EQ(SampleValue(m, "skimap_http_request_seconds_count",
                        {{"route", "GET /v1/maps/{map}"}, {"code", "200"}}),
            1);
  EXPECT_EQ(SampleValue(m, "skimap_http_request_seconds_count",
                        {{"route", "GET /v1/maps/{map}"}, {"code", "404"}}),
            1);
  EXPECT_EQ(SampleValue(m, "skimap_http_request_seconds_count",
                        {{"route", "POST /v1/maps/{map}:radiusSearch"}, {"code", "200"}}),
            1);

  // The scrape itself is counted (by the next one); a deleted map leaves the gauges.
  {
    grpc::ClientContext ctx;
    v1::DeleteMapRequest del;
    del.set_name("maps/m");
    v1::DeleteMapResponse r;
    ASSERT_TRUE(stub->DeleteMap(&ctx, del, &r).ok());
  }
  const std::vector<Sample> after = ParseExposition(http.Get("/metrics")->body);
  EXPECT_EQ(SampleValue(after, "skimap_http_request_seconds_count",
                        {{"route", "GET /metrics"}, {"code", "200"}}),
            1);
  EXPECT_EQ(SampleValue(after, "skimap_map_voxels", {{"map", "maps/m"}}), -1);
  EXPECT_EQ(SampleValue(after, "skimap_frames_ingested_total"), acked);
  EXPECT_EQ(server.Stop(), 0);
}

}  // namespace
}  // namespace skimap::testing
