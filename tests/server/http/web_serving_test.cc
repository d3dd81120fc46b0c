// The viewer's side of skimapd's HTTP adapter: static files from --web_root (MIME types,
// caching headers, 404, no path outside the root) and the live updates of
// GET /v1/maps/{map}/events (server-sent events), over real sockets.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <future>
#include <string>
#include <thread>

#include "absl/strings/str_cat.h"
#include "server/app/server.h"
#include "tests/server/http/http_client.h"
#include "tests/server/http/rest_json.h"

namespace skimap::testing {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

void WriteFile(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  std::ofstream(path) << text;
}

// A server with the REST adapter serving `web_root`.
// Creates map "live" over REST.
void CreateLiveMap(httplib::Client& http) {
  v1::CreateMapRequest create;
  create.set_map_id("live");
  httplib::Result r = http.Post("/v1/maps", ToJsonBody(create), "application/json");
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200) << r->body;
}

std::unique_ptr<server::Server> StartServer(const std::string& web_root, int max_streams = 4) {
  server::Server::Options options;
  options.grpc.address = "127.0.0.1:0";
  options.http.address = "127.0.0.1:0";
  options.http.threads = 6;
  options.http.web_root = web_root;
  options.events.max_clients = max_streams;
  options.events.heartbeat = absl::Milliseconds(200);
  options.maps.worker_threads = 1;
  auto started = server::Server::Start(options);
  EXPECT_TRUE(started.ok()) << started.status();
  return started.ok() ? *std::move(started) : nullptr;
}

class WebRootTest : public ::testing::Test {
 protected:
  void SetUp() override {
    base_ = fs::temp_directory_path() /
            absl::StrCat("skimap_web_test_", ::getpid(), "_",
                         ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(base_);
    root_ = base_ / "dist";
    WriteFile(root_ / "index.html", "<!doctype html><title>SkiMap</title>");
    WriteFile(root_ / "assets" / "index-3f2a9c.js", "console.log(1);");
    WriteFile(root_ / "assets" / "index-77aa01.css", "body{}");
    WriteFile(root_ / "favicon.svg", "<svg xmlns='http://www.w3.org/2000/svg'/>");
    WriteFile(base_ / "secret.txt", "do not serve");
    fs::create_symlink(base_ / "secret.txt", root_ / "link.txt");
    server_ = StartServer(root_.string());
    ASSERT_NE(server_, nullptr);
    http_ = std::make_unique<httplib::Client>("127.0.0.1", server_->http_port());
  }
  void TearDown() override {
    http_.reset();
    server_.reset();
    fs::remove_all(base_);
  }

  fs::path base_, root_;
  std::unique_ptr<server::Server> server_;
  std::unique_ptr<httplib::Client> http_;
};

TEST_F(WebRootTest, ServesIndexAtRootWithNoCache) {
  httplib::Result r = http_->Get("/");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
  EXPECT_EQ(r->get_header_value("Content-Type"), "text/html; charset=utf-8");
  EXPECT_EQ(r->get_header_value("Cache-Control"), "no-cache");
  EXPECT_THAT(r->body, HasSubstr("<title>SkiMap</title>"));
  httplib::Result again = http_->Get("/index.html");
  ASSERT_TRUE(again);
  EXPECT_EQ(again->body, r->body);
}

TEST_F(WebRootTest, HashedAssetsAreImmutableWithTheirMimeTypes) {
  httplib::Result js = http_->Get("/assets/index-3f2a9c.js");
  ASSERT_TRUE(js);
  EXPECT_EQ(js->status, 200);
  EXPECT_EQ(js->get_header_value("Content-Type"), "application/javascript; charset=utf-8");
  EXPECT_EQ(js->get_header_value("Cache-Control"), "public, max-age=31536000, immutable");
  EXPECT_EQ(js->body, "console.log(1);");
  httplib::Result css = http_->Get("/assets/index-77aa01.css");
  ASSERT_TRUE(css);
  EXPECT_EQ(css->get_header_value("Content-Type"), "text/css; charset=utf-8");
  httplib::Result svg = http_->Get("/favicon.svg");
  ASSERT_TRUE(svg);
  EXPECT_EQ(svg->get_header_value("Content-Type"), "image/svg+xml");
  EXPECT_EQ(svg->get_header_value("Cache-Control"), "no-cache");
}

TEST_F(WebRootTest, MissingFilesAnswer404AndTheApiKeepsItsOwn) {
  httplib::Result r = http_->Get("/nope.js");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 404);
  EXPECT_EQ(r->get_header_value("Content-Type"), "application/json");
  httplib::Result api = http_->Get("/v1/nope");
  ASSERT_TRUE(api);
  EXPECT_EQ(api->status, 404);
  EXPECT_THAT(api->body, HasSubstr("no route"));
  httplib::Result maps = http_->Get("/v1/maps");
  ASSERT_TRUE(maps);
  EXPECT_EQ(maps->status, 200);
}

TEST_F(WebRootTest, PathsOutsideTheRootAreRefused) {
  for (const char* path : {"/../secret.txt", "/assets/../../secret.txt", "/%2e%2e/secret.txt",
                           "/assets/%2E%2E/%2e%2e/secret.txt", "/link.txt", "/./index.html",
                           "/assets//index-3f2a9c.js", "/..%2fsecret.txt", "/.hidden"}) {
    httplib::Result r = http_->Get(path);
    ASSERT_TRUE(r) << path;
    EXPECT_EQ(r->status, 404) << path;
    EXPECT_THAT(r->body, ::testing::Not(HasSubstr("do not serve"))) << path;
  }
}

TEST(WebRootStartTest, RootWithoutIndexIsRefused) {
  server::Server::Options options;
  options.grpc.address = "127.0.0.1:0";
  options.http.address = "127.0.0.1:0";
  options.http.web_root = "/nonexistent/skimap/web";
  auto started = server::Server::Start(options);
  EXPECT_EQ(started.status().code(), absl::StatusCode::kNotFound);
  EXPECT_THAT(started.status().message(), HasSubstr("--web_root"));
}

TEST(WebRootStartTest, NoWebRootMeansNoViewer) {
  std::unique_ptr<server::Server> server = StartServer("");
  ASSERT_NE(server, nullptr);
  httplib::Client http("127.0.0.1", server->http_port());
  httplib::Result r = http.Get("/");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 404);
}

// A `width` x 3/4 `width` frame (53 degrees wide) seeing a wall at 1 m, 1 m wide.
v1::Frame WallFrame(const std::string& map, uint64_t sequence, int width = 40) {
  const int height = width * 3 / 4;
  v1::Frame frame;
  frame.set_map(map);
  frame.set_sequence(sequence);
  frame.mutable_pose()->mutable_rotation()->set_w(1);
  frame.mutable_pose()->mutable_translation()->set_x(0.05 * sequence);
  v1::CameraIntrinsics* k = frame.mutable_intrinsics();
  k->set_fx(width);
  k->set_fy(width);
  k->set_cx(width / 2.0);
  k->set_cy(height / 2.0);
  k->set_width(width);
  k->set_height(height);
  frame.set_depth_encoding(v1::DEPTH_ENCODING_RAW_U16);
  std::string depth;
  for (int i = 0; i < width * height; ++i) depth += std::string("\xe8\x03", 2);  // 1000 mm
  frame.set_depth(depth);
  frame.set_depth_scale(0.001);
  return frame;
}

// Reads an event stream on its own thread; collects its text.
class EventReader {
 public:
  EventReader(int port, const std::string& path) {
    thread_ = std::thread([this, port, path] {
      httplib::Client http("127.0.0.1", port);
      http.set_read_timeout(30);
      http.Get(path, [this](const char* data, size_t size) {
        std::lock_guard<std::mutex> lock(mu_);
        text_.append(data, size);
        return !stop_;
      });
      std::lock_guard<std::mutex> lock(mu_);
      done_ = true;
    });
  }
  ~EventReader() {
    {
      std::lock_guard<std::mutex> lock(mu_);
      stop_ = true;
    }
    thread_.join();
  }
  // Waits until the text holds `count` occurrences of `needle`.
  bool WaitFor(const std::string& needle, int count) {
    for (int i = 0; i < 1000; ++i) {
      {
        std::lock_guard<std::mutex> lock(mu_);
        int found = 0;
        for (size_t at = text_.find(needle); at != std::string::npos;
             at = text_.find(needle, at + 1)) {
          ++found;
        }
        if (found >= count) return true;
        if (done_) return false;  // the response ended (an error, or the stream closed)
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return false;
  }
  std::string text() {
    std::lock_guard<std::mutex> lock(mu_);
    return text_;
  }

 private:
  std::mutex mu_;
  std::string text_;
  bool stop_ = false;
  bool done_ = false;
  std::thread thread_;
};

TEST(MapEventsTest, StreamSendsTheMapThenAnEventPerFrame) {
  std::unique_ptr<server::Server> server = StartServer("");
  ASSERT_NE(server, nullptr);
  httplib::Client http("127.0.0.1", server->http_port());
  ASSERT_NO_FATAL_FAILURE(CreateLiveMap(http));

  EventReader events(server->http_port(), "/v1/maps/live/events");
  ASSERT_TRUE(events.WaitFor("event: map\n", 1)) << events.text();
  EXPECT_THAT(events.text(), HasSubstr("\"frames\":\"0\""));
  httplib::Result ack =
      http.Post("/v1/maps/live/frames", ToJsonBody(WallFrame("maps/live", 1)), "application/json");
  ASSERT_TRUE(ack);
  ASSERT_EQ(ack->status, 200) << ack->body;
  ASSERT_TRUE(events.WaitFor("event: map\n", 2)) << events.text();
  ASSERT_TRUE(events.WaitFor("\"frames\":\"1\"", 1)) << events.text();
  EXPECT_TRUE(events.WaitFor(": keep-alive", 1)) << events.text();  // heartbeat 200 ms
}

TEST(MapEventsTest, UnknownMapIs404AndStreamsAreBounded) {
  std::unique_ptr<server::Server> server = StartServer("", /*max_streams=*/1);
  ASSERT_NE(server, nullptr);
  httplib::Client http("127.0.0.1", server->http_port());
  EXPECT_EQ(http.Get("/v1/maps/nope/events")->status, 404);
  ASSERT_NO_FATAL_FAILURE(CreateLiveMap(http));
  {
    EventReader first(server->http_port(), "/v1/maps/live/events");
    ASSERT_TRUE(first.WaitFor("event: map\n", 1));
    httplib::Result second = http.Get("/v1/maps/live/events");
    ASSERT_TRUE(second);
    EXPECT_EQ(second->status, 429);
    EXPECT_THAT(second->body, HasSubstr("--http_max_event_streams"));
  }
  // The first client left: its slot is free again once the server noticed (heartbeat).
  bool reopened = false;
  for (int i = 0; i < 100 && !reopened; ++i) {
    EventReader again(server->http_port(), "/v1/maps/live/events");
    reopened = again.WaitFor("event: map\n", 1);
    if (!reopened) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  EXPECT_TRUE(reopened);
}

TEST(MapEventsTest, DeletedMapEndsTheStream) {
  std::unique_ptr<server::Server> server = StartServer("");
  ASSERT_NE(server, nullptr);
  httplib::Client http("127.0.0.1", server->http_port());
  ASSERT_NO_FATAL_FAILURE(CreateLiveMap(http));
  EventReader events(server->http_port(), "/v1/maps/live/events");
  ASSERT_TRUE(events.WaitFor("event: map\n", 1));
  ASSERT_EQ(http.Delete("/v1/maps/live")->status, 200);
  EXPECT_TRUE(events.WaitFor("event: gone\n", 1)) << events.text();
}

TEST(MapEventsTest, ShutdownEndsOpenStreamsPromptly) {
  std::unique_ptr<server::Server> server = StartServer("");
  ASSERT_NE(server, nullptr);
  httplib::Client http("127.0.0.1", server->http_port());
  ASSERT_NO_FATAL_FAILURE(CreateLiveMap(http));
  EventReader a(server->http_port(), "/v1/maps/live/events");
  EventReader b(server->http_port(), "/v1/maps/live/events");
  ASSERT_TRUE(a.WaitFor("event: map\n", 1));
  ASSERT_TRUE(b.WaitFor("event: map\n", 1));
  const auto start = std::chrono::steady_clock::now();
  server->Shutdown();
  server.reset();
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(5));
}

TEST(VoxelLevelTest, CoarserLevelsMergeBlocksAndPage) {
  std::unique_ptr<server::Server> server = StartServer("");
  ASSERT_NE(server, nullptr);
  httplib::Client http("127.0.0.1", server->http_port());
  v1::CreateMapRequest create;
  create.set_map_id("lod");
  create.mutable_options()->set_resolution(0.01);
  ASSERT_EQ(http.Post("/v1/maps", ToJsonBody(create), "application/json")->status, 200);
  for (uint64_t i = 0; i < 3; ++i) {
    ASSERT_EQ(
        http.Post("/v1/maps/lod/frames", ToJsonBody(WallFrame("maps/lod", i)), "application/json")
            ->status,
        200);
  }
  auto voxels = [&](const std::string& query) {
    return ParseJson<v1::GetVoxelsResponse>(http.Get("/v1/maps/lod/voxels?" + query));
  };
  const v1::GetVoxelsResponse fine = voxels("pageSize=100000");
  const v1::GetVoxelsResponse coarse = voxels("pageSize=100000&level=2");
  ASSERT_GT(fine.voxels_size(), 1000);
  EXPECT_DOUBLE_EQ(fine.resolution(), 0.01);
  EXPECT_DOUBLE_EQ(coarse.resolution(), 0.04);
  // Blocks of 4 x 4 x 4 voxels: far fewer, never more than 64 voxels in one.
  EXPECT_LT(coarse.voxels_size(), fine.voxels_size() / 2);
  EXPECT_GE(coarse.voxels_size(), fine.voxels_size() / 64);
  double fine_weight = 0, coarse_weight = 0;
  for (const v1::Voxel& v : fine.voxels()) fine_weight += v.weight();
  for (const v1::Voxel& v : coarse.voxels()) coarse_weight += v.weight();
  EXPECT_NEAR(coarse_weight, fine_weight, 1e-3 * fine_weight);
  // Paged in small pages: the same blocks in the same order.
  std::vector<std::string> paged;
  std::string token;
  do {
    const v1::GetVoxelsResponse page =
        voxels("pageSize=37&level=2" + (token.empty() ? "" : "&pageToken=" + token));
    for (const v1::Voxel& v : page.voxels()) paged.push_back(v.SerializeAsString());
    token = page.next_page_token();
  } while (!token.empty());
  ASSERT_EQ(paged.size(), size_t(coarse.voxels_size()));
  for (int i = 0; i < coarse.voxels_size(); ++i) {
    EXPECT_EQ(paged[i], coarse.voxels(i).SerializeAsString()) << i;
  }
  httplib::Result bad = http.Get("/v1/maps/lod/voxels?level=9");
  ASSERT_TRUE(bad);
  EXPECT_EQ(bad->status, 400);
  EXPECT_THAT(bad->body, HasSubstr("level must be in 0..8"));
}

TEST(TrajectoryTest, EveryFramesPoseBySequenceThinnedOnRequest) {
  std::unique_ptr<server::Server> server = StartServer("");
  ASSERT_NE(server, nullptr);
  httplib::Client http("127.0.0.1", server->http_port());
  v1::CreateMapRequest create;
  create.set_map_id("walk");
  ASSERT_EQ(http.Post("/v1/maps", ToJsonBody(create), "application/json")->status, 200);
  for (uint64_t i = 0; i < 5; ++i) {
    ASSERT_EQ(http.Post("/v1/maps/walk/frames", ToJsonBody(WallFrame("maps/walk", 10 + i)),
                        "application/json")
                  ->status,
              200);
  }
  const v1::Trajectory all = ParseJson<v1::Trajectory>(http.Get("/v1/maps/walk/trajectory"));
  EXPECT_EQ(all.frames(), 5u);
  ASSERT_EQ(all.poses_size(), 5);
  for (int i = 0; i < 5; ++i) {
    EXPECT_EQ(all.poses(i).sequence(), 10u + i);
    EXPECT_NEAR(all.poses(i).pose().translation().x(), 0.05 * (10 + i), 1e-9);
    EXPECT_NEAR(all.poses(i).pose().rotation().w(), 1, 1e-9);
  }
  const v1::Trajectory thin =
      ParseJson<v1::Trajectory>(http.Get("/v1/maps/walk/trajectory?maxPoses=3"));
  EXPECT_EQ(thin.frames(), 5u);
  ASSERT_EQ(thin.poses_size(), 3);
  EXPECT_EQ(thin.poses(0).sequence(), 10u);
  EXPECT_EQ(thin.poses(1).sequence(), 12u);
  EXPECT_EQ(thin.poses(2).sequence(), 14u);
  EXPECT_EQ(http.Get("/v1/maps/walk/trajectory?maxPoses=-1")->status, 400);
  EXPECT_EQ(http.Get("/v1/maps/nope/trajectory")->status, 404);
}

}  // namespace
}  // namespace skimap::testing
