// End to end with processes: skimapd as a child process on a real port, frames from the
// client library, files from the `skimap` CLI, clean stop on SIGTERM; `skimap stream` of
// real sensor frames with each depth encoding (zstd by default), a bad one refused by name.
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <utility>

#include "absl/strings/str_cat.h"
#include "client/map_client.h"
#include "tests/common/free_port.h"
#include "tests/common/spawn.h"
#include "tests/common/synthetic_scene.h"

namespace skimap::testing {
namespace {

// skimapd as a child process on a free loopback port, its files under a fresh `dir`. A
// test that stops early (a failed ASSERT) kills it on the way out: an orphaned skimapd
// keeps the test's output pipe open, and ctest would wait for it until its timeout.
struct ChildServer {
  std::string dir, address;
  pid_t pid = -1;  // -1: none, or reaped
  std::unique_ptr<client::MapClient> client;

  ChildServer() = default;
  ChildServer(ChildServer&& o) noexcept
      : dir(std::move(o.dir)),
        address(std::move(o.address)),
        pid(std::exchange(o.pid, -1)),
        client(std::move(o.client)) {}
  ChildServer& operator=(ChildServer&&) = delete;
  ~ChildServer() { KillAndReap(pid); }
};

ChildServer StartSkimapd(const std::string& name) {
  ChildServer s;
  s.dir = (std::filesystem::temp_directory_path() / absl::StrCat(name, "_", getpid())).string();
  std::filesystem::create_directories(s.dir);
  s.address = absl::StrCat("127.0.0.1:", FreePort());
  s.pid = SpawnProcess({SKIMAPD_PATH, "--address=" + s.address, "--data_dir=" + s.dir + "/d",
                        "--worker_threads=1", "--http_address="});
  if (s.pid >= 0) s.client = client::MapClient::Connect(s.address);
  return s;
}

// Sends SIGTERM and waits; the wait status (-1 if it cannot be had).
int StopSkimapd(ChildServer& s) {
  int status = -1;
  if (kill(s.pid, SIGTERM) != 0 || waitpid(s.pid, &status, 0) != s.pid) return -1;
  s.pid = -1;
  return status;
}

TEST(ProcessTest, SkimapdServesTheCliAndStopsCleanlyOnSigterm) {
  ChildServer server = StartSkimapd("skimap_process_test");
  ASSERT_GE(server.pid, 0);
  const std::string& dir = server.dir;
  const std::string& address = server.address;
  client::MapClient* client = server.client.get();
  ASSERT_TRUE(client->WaitForServer(absl::Seconds(20)).ok());
  v1::CreateMapRequest create;
  create.set_map_id("proc");
  ASSERT_TRUE(client->CreateMap(create).ok());
  auto ack = client->IntegrateFrame(MakeFrame("maps/proc", 1, DefaultView()));
  ASSERT_TRUE(ack.ok()) << ack.status();

  const std::string yaml = dir + "/grid.yaml";
  const std::string command =
      absl::StrCat(SKIMAP_CLI_PATH, " --server=", address, " grid --map=proc -o ", yaml);
  ASSERT_EQ(std::system(command.c_str()), 0);
  std::ifstream pgm(dir + "/grid.pgm", std::ios::binary);
  std::string magic;
  int width = 0, height = 0;
  pgm >> magic;
  pgm.ignore(1000, '\n');  // end of the magic line
  pgm.ignore(1000, '\n');  // the comment line
  pgm >> width >> height;
  EXPECT_EQ(magic, "P5");
  // Measured 2026-11-23: 80 x 112 cells for the mini scene; floors at two thirds.
  EXPECT_GE(width, 54);
  EXPECT_GE(height, 75);
  std::ifstream yaml_in(yaml);
  std::stringstream text;
  text << yaml_in.rdbuf();
  EXPECT_NE(text.str().find("mode: trinary"), std::string::npos);

  const int status = StopSkimapd(server);
  ASSERT_NE(status, -1);
  EXPECT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0);
  std::filesystem::remove_all(dir);
}

TEST(ProcessTest, CliStreamsRealFramesInEveryDepthEncodingAndRefusesAnUnknownOne) {
  ChildServer server = StartSkimapd("skimap_stream_cli");
  ASSERT_GE(server.pid, 0);
  const std::string& dir = server.dir;
  client::MapClient* client = server.client.get();
  ASSERT_TRUE(client->WaitForServer(absl::Seconds(20)).ok());
  const std::string scene = SKIMAP_YCBV_DIR "/test/000000";
  auto stream = [&](const std::string& map, const std::string& flags) {
    const std::string command =
        absl::StrCat(SKIMAP_CLI_PATH, " --server=", server.address, " stream ", scene,
                     " --map=", map, " --resolution=0.01 ", flags, " > ", dir, "/out.txt 2>&1");
    return std::system(command.c_str());
  };
  // Every encoding gives the same map: depth is lossless in each.
  uint64_t voxels = 0;
  for (const std::string encoding : {"", "auto", "zstd", "rvl", "png16", "raw"}) {
    const std::string map = encoding.empty() ? "default" : encoding;
    ASSERT_EQ(stream(map, encoding.empty() ? "" : "--depth_encoding=" + encoding), 0) << map;
    absl::StatusOr<v1::Map> m = client->GetMap("maps/" + map);
    ASSERT_TRUE(m.ok()) << m.status();
    EXPECT_EQ(m->stats().frames(), 10u) << map;
    if (voxels == 0) voxels = m->stats().voxels();
    EXPECT_EQ(m->stats().voxels(), voxels) << map;
  }
  EXPECT_GT(voxels, 1000u);
  EXPECT_NE(stream("bad", "--depth_encoding=lzw"), 0);
  std::ifstream out(dir + "/out.txt");
  std::stringstream text;
  text << out.rdbuf();
  EXPECT_NE(text.str().find("--depth_encoding"), std::string::npos) << text.str();
  EXPECT_FALSE(client->GetMap("maps/bad").ok());  // nothing created

  EXPECT_NE(StopSkimapd(server), -1);
  std::filesystem::remove_all(dir);
}

TEST(ProcessTest, CliSetsEveryMapOptionAndRefusesBadOnesByName) {
  ChildServer server = StartSkimapd("skimap_map_options_cli");
  ASSERT_GE(server.pid, 0);
  const std::string& dir = server.dir;
  client::MapClient* client = server.client.get();
  ASSERT_TRUE(client->WaitForServer(absl::Seconds(20)).ok());
  // Runs the CLI; its exit code, and its output in *text.
  auto run = [&](const std::string& args, std::string* text) {
    const std::string command = absl::StrCat(SKIMAP_CLI_PATH, " --server=", server.address, " ",
                                             args, " > ", dir, "/out.txt 2>&1");
    const int code = std::system(command.c_str());
    std::ifstream out(dir + "/out.txt");
    std::stringstream buffer;
    buffer << out.rdbuf();
    *text = buffer.str();
    return code;
  };
  std::string text;
  ASSERT_EQ(run("maps create tuned --resolution=0.02 --min_depth=0.3 --max_depth=3.5 "
                "--min_voxel_weight=2 --band_min_z=0.1 --band_max_z=1.2 --floor_min_z=-0.2 "
                "--pixel_stride=2 --carve_free_space=false --carve_pixel_stride=8",
                &text),
            0)
      << text;
  absl::StatusOr<v1::Map> tuned = client->GetMap("maps/tuned");
  ASSERT_TRUE(tuned.ok()) << tuned.status();
  const v1::MapOptions& o = tuned->options();
  EXPECT_DOUBLE_EQ(o.resolution(), 0.02);
  EXPECT_DOUBLE_EQ(o.min_depth(), 0.3);
  EXPECT_DOUBLE_EQ(o.max_depth(), 3.5);
  EXPECT_FLOAT_EQ(o.min_voxel_weight(), 2);
  EXPECT_DOUBLE_EQ(o.band_min_z(), 0.1);
  EXPECT_DOUBLE_EQ(o.band_max_z(), 1.2);
  EXPECT_DOUBLE_EQ(o.floor_min_z(), -0.2);
  EXPECT_EQ(o.pixel_stride(), 2u);
  EXPECT_FALSE(o.carve_free_space());
  EXPECT_EQ(o.carve_pixel_stride(), 8u);
  // Without flags, the server's defaults: carving on.
  ASSERT_EQ(run("maps create plain", &text), 0) << text;
  absl::StatusOr<v1::Map> plain = client->GetMap("maps/plain");
  ASSERT_TRUE(plain.ok()) << plain.status();
  EXPECT_TRUE(plain->options().carve_free_space());
  EXPECT_DOUBLE_EQ(plain->options().band_min_z(), 0.05);
  // A bad value: the API's message naming the field, nothing created.
  EXPECT_NE(run("maps create bad --band_min_z=2 --band_max_z=1", &text), 0);
  EXPECT_NE(text.find("options.band_min_z"), std::string::npos) << text;
  EXPECT_NE(run("maps create bad --carve_pixel_stride=0", &text), 0);
  EXPECT_NE(text.find("options.carve_pixel_stride"), std::string::npos) << text;
  EXPECT_NE(run("maps create bad --band_max_z=high", &text), 0);
  EXPECT_NE(text.find("--band_max_z: not a number"), std::string::npos) << text;
  EXPECT_FALSE(client->GetMap("maps/bad").ok());
  // stream: creates with the flags; into an existing map, a disagreeing flag is refused.
  const std::string scene = SKIMAP_YCBV_DIR "/test/000000";
  ASSERT_EQ(
      run("stream " + scene + " --map=streamed --max_depth=1.2 --carve_free_space=false", &text), 0)
      << text;
  absl::StatusOr<v1::Map> streamed = client->GetMap("maps/streamed");
  ASSERT_TRUE(streamed.ok()) << streamed.status();
  EXPECT_DOUBLE_EQ(streamed->options().max_depth(), 1.2);
  EXPECT_EQ(streamed->stats().free_voxels(), 0u);
  EXPECT_NE(run("stream " + scene + " --map=streamed --max_depth=2", &text), 0);
  EXPECT_NE(text.find("max_depth"), std::string::npos) << text;
  EXPECT_EQ(client->GetMap("maps/streamed")->stats().frames(), 10u) << "nothing streamed";
  ASSERT_EQ(run("stream " + scene + " --map=streamed --max_depth=1.2", &text), 0) << text;
  EXPECT_EQ(client->GetMap("maps/streamed")->stats().frames(), 20u) << "agreeing flags stream";

  EXPECT_NE(StopSkimapd(server), -1);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace skimap::testing
