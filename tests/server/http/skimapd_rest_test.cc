// skimapd's HTTP flags, against the real daemon: --http_address (loopback unless
// --insecure, empty = off, a taken port stops the start), --http_max_body_mb,
// --http_cors_origins; and one map store behind both transports.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdio>
#include <filesystem>
#include <string>
#include <utility>

#include "absl/strings/str_cat.h"
#include "client/map_client.h"
#include "tests/common/skimapd_process.h"
#include "tests/server/http/http_client.h"
#include "tests/server/http/rest_json.h"

namespace skimap::testing {
namespace {

using ::testing::HasSubstr;

// Runs skimapd with `flags` (and a throwaway data dir) until it exits; its exit code and
// output.
std::pair<int, std::string> RunToExit(const std::string& flags) {
  const std::string dir =
      (std::filesystem::temp_directory_path() / absl::StrCat("skimapd_rest_", getpid())).string();
  const std::string command = absl::StrCat(SKIMAPD_PATH, " --data_dir=", dir, " ", flags, " 2>&1");
  FILE* out = popen(command.c_str(), "r");
  std::string text;
  char buf[512];
  while (fgets(buf, sizeof buf, out) != nullptr) text += buf;
  const int status = pclose(out);
  std::filesystem::remove_all(dir);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, text};
}

TEST(SkimapdRestTest, RestAndGrpcServeTheSameMaps) {
  SkimapdProcess server(SKIMAPD_PATH, {"--worker_threads=1"});
  ASSERT_TRUE(server.Start().ok());
  httplib::Client http("127.0.0.1", server.http_port());
  EXPECT_EQ(ParseJson<v1::HealthzResponse>(http.Get("/healthz")).status(), "SERVING");
  ParseJson<v1::Map>(http.Post("/v1/maps", R"({"mapId": "by_rest"})", kJson));
  auto grpc = client::MapClient::Connect(server.address());
  EXPECT_TRUE(grpc->GetMap("maps/by_rest").ok());
  v1::CreateMapRequest create;
  create.set_map_id("by_grpc");
  ASSERT_TRUE(grpc->CreateMap(create).ok());
  const auto listed = ParseJson<v1::ListMapsResponse>(http.Get("/v1/maps"));
  ASSERT_EQ(listed.maps_size(), 2);
  EXPECT_EQ(listed.maps(0).name(), "maps/by_grpc");
  EXPECT_EQ(listed.maps(1).name(), "maps/by_rest");
  EXPECT_EQ(server.Stop(), 0);  // SIGTERM stops both adapters cleanly
}

TEST(SkimapdRestTest, AnHttpAddressBeyondLoopbackNeedsInsecure) {
  const auto [code, text] = RunToExit(
      absl::StrCat("--address=127.0.0.1:", FreePort(), " --http_address=0.0.0.0:", FreePort()));
  EXPECT_EQ(code, 1);
  EXPECT_THAT(text, HasSubstr("--http_address 0.0.0.0:"));
  EXPECT_THAT(text, HasSubstr("beyond loopback"));
  EXPECT_THAT(text, HasSubstr("--insecure"));
  SkimapdProcess wide(SKIMAPD_PATH,
                      {"--insecure", absl::StrCat("--http_address=0.0.0.0:", FreePort())});
  EXPECT_TRUE(wide.Start().ok());
}

TEST(SkimapdRestTest, AnEmptyHttpAddressTurnsRestOff) {
  SkimapdProcess server(SKIMAPD_PATH, {"--http_address="});
  ASSERT_TRUE(server.Start().ok());
  httplib::Client http("127.0.0.1", server.http_port());
  http.set_connection_timeout(2);
  EXPECT_FALSE(http.Get("/healthz"));
}

TEST(SkimapdRestTest, AnHttpPortInUseStopsTheStart) {
  SkimapdProcess first(SKIMAPD_PATH, {});
  ASSERT_TRUE(first.Start().ok());
  const auto [code, text] = RunToExit(absl::StrCat(
      "--address=127.0.0.1:", FreePort(), " --http_address=127.0.0.1:", first.http_port()));
  EXPECT_EQ(code, 1);
  EXPECT_THAT(text, HasSubstr("cannot listen on 127.0.0.1:"));
  EXPECT_THAT(text, HasSubstr("--http_address"));
}

TEST(SkimapdRestTest, FlagsSetTheBodyLimitAndTheCorsOrigins) {
  SkimapdProcess server(SKIMAPD_PATH, {"--http_max_body_mb=1",
                                       "--http_cors_origins=https://a.example, https://b.example"});
  ASSERT_TRUE(server.Start().ok());
  httplib::Client http("127.0.0.1", server.http_port());
  const v1::RestError large =
      ParseError(http.Post("/v1/maps", std::string((1 << 20) + 1, ' '), kJson), 413);
  EXPECT_THAT(large.message(), HasSubstr("limit of 1048576 bytes (skimapd --http_max_body_mb)"));
  // Just under the limit, the body reaches the JSON parser.
  EXPECT_EQ(ParseError(http.Post("/v1/maps", std::string(1 << 20, ' '), kJson), 400).status(),
            "INVALID_ARGUMENT");
  for (const char* origin : {"https://a.example", "https://b.example"}) {
    httplib::Result r =
        http.Options("/v1/maps", {{"Origin", origin}, {"Access-Control-Request-Method", "POST"}});
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, 204) << origin;
    EXPECT_EQ(r->get_header_value("Access-Control-Allow-Origin"), origin);
  }
  ParseError(http.Options("/v1/maps", {{"Origin", "https://c.example"},
                                       {"Access-Control-Request-Method", "POST"}}),
             403);
}

TEST(SkimapdRestTest, OutOfRangeHttpFlagsAreRefused) {
  for (const char* flag : {"--http_max_body_mb=0", "--http_threads=0"}) {
    EXPECT_EQ(RunToExit(flag).first, 2) << flag;
  }
}

}  // namespace
}  // namespace skimap::testing
