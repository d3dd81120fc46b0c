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

#include "absl/strings/str_cat.h"
#include "client/map_client.h"
#include "tests/common/free_port.h"
#include "tests/common/spawn.h"
#include "tests/server/synthetic_scene.h"

namespace skimap::testing {
namespace {

TEST(ProcessTest, SkimapdServesTheCliAndStopsCleanlyOnSigterm) {
  const std::string dir =
      (std::filesystem::temp_directory_path() / absl::StrCat("skimap_process_test_", getpid()))
          .string();
  std::filesystem::create_directories(dir);
  const std::string address = absl::StrCat("127.0.0.1:", FreePort());
  const pid_t pid = SpawnProcess({SKIMAPD_PATH, "--address=" + address, "--data_dir=" + dir + "/d",
                                  "--worker_threads=1", "--http_address="});
  ASSERT_GE(pid, 0);
  std::unique_ptr<client::MapClient> client = client::MapClient::Connect(address);
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

  ASSERT_EQ(kill(pid, SIGTERM), 0);
  int status = 0;
  ASSERT_EQ(waitpid(pid, &status, 0), pid);
  EXPECT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0);
  std::filesystem::remove_all(dir);
}

TEST(ProcessTest, CliStreamsRealFramesInEveryDepthEncodingAndRefusesAnUnknownOne) {
  const std::string dir =
      (std::filesystem::temp_directory_path() / absl::StrCat("skimap_stream_cli_", getpid()))
          .string();
  std::filesystem::create_directories(dir);
  const std::string address = absl::StrCat("127.0.0.1:", FreePort());
  const pid_t pid = SpawnProcess({SKIMAPD_PATH, "--address=" + address, "--data_dir=" + dir + "/d",
                                  "--worker_threads=1", "--http_address="});
  ASSERT_GE(pid, 0);
  std::unique_ptr<client::MapClient> client = client::MapClient::Connect(address);
  ASSERT_TRUE(client->WaitForServer(absl::Seconds(20)).ok());
  const std::string scene = SKIMAP_YCBV_DIR "/test/000000";
  auto stream = [&](const std::string& map, const std::string& flags) {
    const std::string command =
        absl::StrCat(SKIMAP_CLI_PATH, " --server=", address, " stream ", scene, " --map=", map,
                     " --resolution=0.01 ", flags, " > ", dir, "/out.txt 2>&1");
    return std::system(command.c_str());
  };
  // Every encoding gives the same map: depth is lossless in each.
  uint64_t voxels = 0;
  for (const std::string encoding : {"", "zstd", "rvl", "png16", "raw"}) {
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

  ASSERT_EQ(kill(pid, SIGTERM), 0);
  int status = 0;
  ASSERT_EQ(waitpid(pid, &status, 0), pid);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace skimap::testing
