// skimap-ros on a map with recognition (the recognition world's server and its `scene`
// map): the bridge, a real rosmaster and a probe node (tests/ros/ros_probe.cc) as
// processes. Every instance skimapd lists appears as an arrow and a text marker on
// `instances`, as a tf frame object_<id>, and in the instances_in_sphere service.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>

#include <cstdio>
#include <cstdlib>
#include <set>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "tests/common/free_port.h"
#include "tests/common/spawn.h"
#include "tests/server/recognition/recognition_fixture.h"

namespace skimap::testing {
namespace {

std::string Capture(const std::string& command) {
  std::string out;
  FILE* pipe = popen((command + " 2>&1").c_str(), "r");
  if (pipe == nullptr) return out;
  char buffer[4096];
  size_t n = 0;
  while ((n = fread(buffer, 1, sizeof buffer, pipe)) > 0) out.append(buffer, n);
  pclose(pipe);
  return out;
}

TEST(RosMarkersTest, EveryInstanceIsAMarkerATfFrameAndInTheSphereService) {
  RecognitionWorld& w = World();
  const std::vector<v1::Instance> instances = AllInstances(*w.client, "maps/scene");
  ASSERT_FALSE(instances.empty());
  const int port = FreePort();
  const std::string master_uri = absl::StrCat("http://127.0.0.1:", port);
  setenv("ROS_MASTER_URI", master_uri.c_str(), 1);
  setenv("ROS_IP", "127.0.0.1", 1);
  pid_t master = SpawnProcess(
      {"/usr/bin/python3", "/usr/bin/rosmaster", "--core", "-p", std::to_string(port)});
  const KillOnExit master_reaper{&master};
  ASSERT_GT(master, 0);
  const std::string log = absl::StrCat(w.data_dir, "/bridge.log");
  SpawnOptions options;
  options.stdout_path = options.stderr_path = log;
  pid_t bridge = SpawnProcess({SKIMAP_ROS_PATH, "__ns:=/robot", "__name:=skimap_ros",
                               absl::StrCat("_server:=127.0.0.1:", w.server->grpc_port()),
                               "_map:=scene", "_fixed_frame:=world", "_publish_rate:=5.0"},
                              options);
  const KillOnExit bridge_reaper{&bridge};
  ASSERT_GT(bridge, 0);
  const std::string out = Capture(absl::StrCat(SKIMAP_ROS_PROBE_PATH, " /robot/instances ",
                                               "/robot/skimap_ros/instances_in_sphere 60"));
  kill(bridge, SIGINT);
  int status = -1;
  waitpid(bridge, &status, 0);
  bridge = 0;
  kill(master, SIGTERM);
  waitpid(master, nullptr, 0);
  master = 0;
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);

  const size_t n = instances.size();
  std::set<std::string> ids;
  for (const v1::Instance& i : instances) ids.insert(absl::StrCat(i.id()));
  int arrows = -1, texts = -1, tf_frames = -1, found = -1;
  std::string service_ids;
  for (absl::string_view line : absl::StrSplit(out, '\n')) {
    std::vector<std::string> f = absl::StrSplit(line, ' ');
    if (f.size() >= 3 && f[0] == "markers") {
      arrows = std::atoi(f[1].c_str());
      texts = std::atoi(f[2].c_str());
    } else if (f.size() >= 2 && f[0] == "tf") {
      tf_frames = std::atoi(f[1].c_str());
    } else if (f.size() >= 3 && f[0] == "sphere" && f[1] == "1") {
      found = std::atoi(f[2].c_str());
      if (f.size() >= 4) service_ids = f[3];
    }
  }
  EXPECT_EQ(arrows, int(n)) << out;
  EXPECT_EQ(texts, int(n)) << out;
  EXPECT_EQ(tf_frames, int(n)) << out;
  EXPECT_EQ(found, int(n)) << out;
  std::set<std::string> listed;
  for (absl::string_view id : absl::StrSplit(service_ids, ',', absl::SkipEmpty())) {
    listed.insert(std::string(id));
  }
  EXPECT_EQ(listed, ids) << out;
  // The texts name the objects.
  EXPECT_NE(out.find(instances[0].object_name().empty() ? instances[0].object()
                                                        : instances[0].object_name()),
            std::string::npos)
      << out;
}

}  // namespace
}  // namespace skimap::testing
