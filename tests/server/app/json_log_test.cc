// skimapd --log_format=json against the real daemon: gRPC and REST calls with and without
// an x-request-id, stderr parsed line by line with a JSON parser (nlohmann-json): one
// object per line, the call's id on its access line and on the core's lines of that call
// (a refused frame is logged on the map's worker), the id echoed to the client, and a
// Bearer token sent with the calls never in the log.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <httplib.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "tests/common/skimapd_process.h"
#include "tests/server/app/test_frames.h"

namespace skimap::testing {
namespace {

using ::testing::HasSubstr;
using ::testing::MatchesRegex;

constexpr char kGrpcSecret[] = "Bearer s3cr3t-grpc-token-0xdeadbeef";
constexpr char kRestSecret[] = "Bearer s3cr3t-rest-token-0xfeedface";

std::string TrailingRequestId(const grpc::ClientContext& ctx) {
  const auto& trailers = ctx.GetServerTrailingMetadata();
  auto it = trailers.find("x-request-id");
  return it == trailers.end() ? "" : std::string(it->second.data(), it->second.size());
}

// The log lines with request id `id`.
std::vector<nlohmann::json> WithId(const std::vector<nlohmann::json>& lines,
                                   const std::string& id) {
  std::vector<nlohmann::json> out;
  for (const nlohmann::json& l : lines) {
    if (l.value("request_id", "") == id) out.push_back(l);
  }
  return out;
}

TEST(JsonLogTest, EveryLineIsJsonAndCarriesTheCallsRequestIdButNoSecret) {
  const std::string log_path =
      (std::filesystem::temp_directory_path() / absl::StrCat("skimapd_json_log_", getpid()))
          .string();
  std::filesystem::remove(log_path);
  SkimapdProcess server(SKIMAPD_PATH, {"--worker_threads=1", "--log_format=json"});
  server.RedirectStderr(log_path);
  ASSERT_TRUE(server.Start().ok());
  auto stub = MapStub(server.address());

  // gRPC: a given id, echoed in the trailing metadata.
  {
    grpc::ClientContext ctx;
    ctx.AddMetadata("x-request-id", "it-create-42");
    ctx.AddMetadata("authorization", kGrpcSecret);
    v1::CreateMapRequest create;
    create.set_map_id("m");
    v1::Map map;
    ASSERT_TRUE(stub->CreateMap(&ctx, create, &map).ok());
    EXPECT_EQ(TrailingRequestId(ctx), "it-create-42");
  }
  // A stream with a good frame and a refused one (refused on the map's worker).
  {
    grpc::ClientContext ctx;
    ctx.AddMetadata("x-request-id", "it-stream-7");
    ctx.AddMetadata("authorization", kGrpcSecret);
    auto stream = stub->StreamFrames(&ctx);
    ASSERT_TRUE(stream->Write(WallFrame("maps/m", 0)));
    ASSERT_TRUE(stream->Write(WallFrame("maps/m", 1, /*width=*/40)));
    stream->WritesDone();
    v1::FrameAck ack;
    int acks = 0;
    while (stream->Read(&ack)) ++acks;
    ASSERT_TRUE(stream->Finish().ok());
    EXPECT_EQ(acks, 2);
    EXPECT_EQ(TrailingRequestId(ctx), "it-stream-7");
  }
  // No id, and an id that must not reach a log line: both get a generated one.
  std::string generated, replaced;
  for (const char* given : {"", "bad id {\"level\":\"error\"}"}) {
    grpc::ClientContext ctx;
    if (*given) ctx.AddMetadata("x-request-id", given);
    v1::GetMapRequest get;
    get.set_name("maps/nope");
    v1::Map map;
    EXPECT_EQ(stub->GetMap(&ctx, get, &map).error_code(), grpc::NOT_FOUND);
    (*given ? replaced : generated) = TrailingRequestId(ctx);
  }
  EXPECT_THAT(generated, MatchesRegex("[0-9a-f]{16}"));
  EXPECT_THAT(replaced, MatchesRegex("[0-9a-f]{16}"));
  EXPECT_NE(generated, replaced);

  // REST: the id in the X-Request-Id response header, success and error alike.
  httplib::Client http("127.0.0.1", server.http_port());
  httplib::Result got =
      http.Get("/v1/maps/m", {{"X-Request-Id", "it-rest-9"}, {"Authorization", kRestSecret}});
  ASSERT_TRUE(got);
  EXPECT_EQ(got->status, 200);
  EXPECT_EQ(got->get_header_value("X-Request-Id"), "it-rest-9");
  httplib::Result bad =
      http.Post("/v1/maps", {{"X-Request-Id", "it-rest-10"}, {"Authorization", kRestSecret}},
                "{not json", "application/json");
  ASSERT_TRUE(bad);
  EXPECT_EQ(bad->status, 400);
  EXPECT_EQ(bad->get_header_value("X-Request-Id"), "it-rest-10");
  EXPECT_EQ(server.Stop(), 0);

  std::ifstream file(log_path);
  std::vector<nlohmann::json> lines;
  std::string text, line;
  while (std::getline(file, line)) {
    text += line + "\n";
    if (line.empty()) continue;
    nlohmann::json parsed = nlohmann::json::parse(line, nullptr, /*allow_exceptions=*/false);
    ASSERT_TRUE(parsed.is_object()) << "not a JSON object: " << line;
    EXPECT_TRUE(parsed["time"].is_string() && parsed["level"].is_string() &&
                parsed["msg"].is_string())
        << line;
    lines.push_back(std::move(parsed));
  }
  std::filesystem::remove(log_path);
  EXPECT_THAT(text, ::testing::Not(HasSubstr("s3cr3t")));
  EXPECT_THAT(text, ::testing::Not(HasSubstr("Bearer")));

  // CreateMap: the core's line and the access line, one id.
  auto create = WithId(lines, "it-create-42");
  ASSERT_EQ(create.size(), 2u) << text;
  EXPECT_EQ(create[0]["msg"], "map maps/m created");
  EXPECT_EQ(create[0]["method"], "skimap.v1.MapService/CreateMap");
  EXPECT_EQ(create[1]["msg"], "call");
  EXPECT_EQ(create[1]["method"], "skimap.v1.MapService/CreateMap");
  EXPECT_EQ(create[1]["map"], "maps/m");
  EXPECT_EQ(create[1]["code"], 0);
  EXPECT_GE(create[1]["latency_ms"].get<double>(), 0.0);

  // The stream: the refused frame's line (written on the map's worker) and the access line.
  auto stream = WithId(lines, "it-stream-7");
  ASSERT_EQ(stream.size(), 2u) << text;
  EXPECT_EQ(stream[0]["level"], "warning");
  EXPECT_THAT(stream[0]["msg"].get<std::string>(), HasSubstr("frame 1 refused: INVALID_ARGUMENT"));
  EXPECT_EQ(stream[0]["map"], "maps/m");
  EXPECT_EQ(stream[0]["code"], 3);
  EXPECT_EQ(stream[1]["method"], "skimap.v1.MapService/StreamFrames");
  EXPECT_EQ(stream[1]["code"], 0);

  for (const std::string& id : {generated, replaced}) {
    auto get = WithId(lines, id);
    ASSERT_EQ(get.size(), 1u) << text;
    EXPECT_EQ(get[0]["method"], "skimap.v1.MapService/GetMap");
    EXPECT_EQ(get[0]["map"], "maps/nope");
    EXPECT_EQ(get[0]["code"], 5);
  }

  auto rest = WithId(lines, "it-rest-9");
  ASSERT_EQ(rest.size(), 1u) << text;
  EXPECT_EQ(rest[0]["route"], "GET /v1/maps/{map}");
  EXPECT_EQ(rest[0]["map"], "maps/m");
  EXPECT_EQ(rest[0]["code"], 200);
  EXPECT_GE(rest[0]["latency_ms"].get<double>(), 0.0);
  auto rest_bad = WithId(lines, "it-rest-10");
  ASSERT_EQ(rest_bad.size(), 1u) << text;
  EXPECT_EQ(rest_bad[0]["route"], "POST /v1/maps");
  EXPECT_EQ(rest_bad[0]["code"], 400);
}

}  // namespace
}  // namespace skimap::testing
