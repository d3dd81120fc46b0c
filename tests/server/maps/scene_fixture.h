// Datasets streamed through a real gRPC server for the scene tests: a skimap-sim `mini`
// scene generated at test time by the skimap-sim binary, and the real ycbv-0000 sample,
// both streamed by the `skimap` CLI (a separate process) into an in-process skimapd on a
// localhost port.
#ifndef TESTS_SERVER_MAPS_SCENE_FIXTURE_H_
#define TESTS_SERVER_MAPS_SCENE_FIXTURE_H_

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>

#include "absl/strings/str_cat.h"
#include "client/map_client.h"
#include "server/app/server.h"

namespace skimap::testing {

// The sim scene used by the tests: mini preset, 40 frames at 3x speed (about 1.2 m of
// the hand-held orbit around the table), no training sequences.
inline constexpr char kSimArgs[] = "--preset mini --no-train --frames 40 --speed 3 --quiet";

// Generates the sim scene once per build of skimap-sim: the output goes to a folder named
// after the binary's modification time (other test processes of the same run reuse it;
// concurrent generators each write a private folder and the first rename wins).
// Returns the scene folder (.../test/000001), or "" after a failed test assertion.
inline std::string GenerateSimScene() {
  namespace fs = std::filesystem;
  const auto stamp = fs::last_write_time(SKIMAP_SIM_PATH).time_since_epoch().count();
  const fs::path root = fs::temp_directory_path() / absl::StrCat("skimap_scene_test_sim_", stamp);
  const fs::path scene = root / "test" / "000001";
  if (!fs::exists(scene / "scene_geometry.json")) {
    const fs::path tmp = fs::temp_directory_path() / absl::StrCat("skimap_sim_gen_", getpid());
    fs::remove_all(tmp);
    const std::string command =
        absl::StrCat(SKIMAP_SIM_PATH, " ", kSimArgs, " --out ", tmp.string(), " >/dev/null");
    EXPECT_EQ(std::system(command.c_str()), 0) << command;
    std::error_code ignored;
    fs::rename(tmp, root, ignored);  // fails harmlessly if another process won
    fs::remove_all(tmp, ignored);
  }
  EXPECT_TRUE(fs::exists(scene / "scene_geometry.json"));
  return scene.string();
}

// An in-process skimapd on 127.0.0.1:<free port>.
inline std::unique_ptr<server::Server> StartServer() {
  server::Server::Options options;
  options.grpc.address = "127.0.0.1:0";
  options.maps.worker_threads = 2;
  auto server = server::Server::Start(options);
  EXPECT_TRUE(server.ok()) << server.status();
  return server.ok() ? *std::move(server) : nullptr;
}

// Streams `dataset` into maps/{map_id} (which must exist) with the `skimap` CLI.
inline void StreamWithCli(int port, const std::string& dataset, const std::string& map_id) {
  const std::string command =
      absl::StrCat(SKIMAP_CLI_PATH, " --server=127.0.0.1:", port, " stream ", dataset,
                   " --map=", map_id, " >/dev/null 2>&1");
  ASSERT_EQ(std::system(command.c_str()), 0) << command;
}

}  // namespace skimap::testing

#endif  // TESTS_SERVER_MAPS_SCENE_FIXTURE_H_
