// `skimap objects` against a real skimapd process: train one sim object from the CLI
// (frames streamed), list it, and see it again after restarting skimapd on its data dir.
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>

#include "absl/strings/str_cat.h"
#include "tests/common/free_port.h"
#include "tests/common/spawn.h"
#include "tests/perception/objects/sim_data.h"

namespace skimap::testing {
namespace {

pid_t StartSkimapd(const std::string& address, const std::string& data_dir) {
  return SpawnProcess({SKIMAPD_PATH, "--address=" + address, "--data_dir=" + data_dir,
                       "--worker_threads=1", "--http_address="});
}

void Stop(pid_t pid) {
  ASSERT_EQ(kill(pid, SIGTERM), 0);
  int status = 0;
  ASSERT_EQ(waitpid(pid, &status, 0), pid);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
}

// Runs the CLI; its exit code and stdout.
int Cli(const std::string& args, std::string* out) {
  FILE* p = popen(absl::StrCat(SKIMAP_CLI_PATH, " ", args, " 2>/dev/null").c_str(), "r");
  char buf[4096];
  out->clear();
  for (size_t n; (n = fread(buf, 1, sizeof buf, p)) > 0;) out->append(buf, n);
  const int status = pclose(p);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// `objects ls` until the server answers (it may still be starting).
int LsWhenUp(const std::string& server, std::string* out) {
  int rc = -1;
  for (int i = 0; i < 100 && rc != 0; ++i) {
    rc = Cli(absl::StrCat("--server=", server, " objects ls"), out);
    if (rc != 0) usleep(100 * 1000);
  }
  return rc;
}

TEST(ObjectsCliTest, TrainAndListAgainstSkimapdAcrossARestart) {
  const std::string mini = objects::testing::MiniDataset();
  const std::string data = objects::testing::TempDir() + "/data";
  const std::string server = absl::StrCat("127.0.0.1:", FreePort());
  pid_t pid = StartSkimapd(server, data);
  ASSERT_GT(pid, 0);
  std::string out;
  ASSERT_EQ(LsWhenUp(server, &out), 0);
  EXPECT_NE(out.find("(no objects)"), std::string::npos) << out;
  ASSERT_EQ(Cli(absl::StrCat("--server=", server, " objects train ", mini,
                             " --object=2 --frame_stride=4"),
                &out),
            0)
      << out;
  EXPECT_NE(out.find("objects/2"), std::string::npos) << out;
  EXPECT_NE(out.find("cereal"), std::string::npos) << out;
  Stop(pid);

  pid = StartSkimapd(server, data);
  ASSERT_EQ(LsWhenUp(server, &out), 0);
  EXPECT_NE(out.find("objects/2"), std::string::npos) << out;
  EXPECT_EQ(Cli(absl::StrCat("--server=", server, " objects rm 7"), &out), 1);
  EXPECT_EQ(Cli(absl::StrCat("--server=", server, " objects rm 2"), &out), 0);
  Stop(pid);
  EXPECT_TRUE(std::filesystem::exists(data + "/objects.sqlite"));
}

// `objects add MODEL`: a textured OBJ the sim wrote becomes an object trained from its
// rendered views (3 orbits of 12 here); a model file that is not one is refused and trains nothing.
TEST(ObjectsCliTest, AddTrainsAnObjectFromItsTexturedModel) {
  const std::string mini = objects::testing::MiniDataset();
  const std::string temp = objects::testing::TempDir();  // fresh on each call: once
  const std::string data = temp + "/data_add";
  const std::string server = absl::StrCat("127.0.0.1:", FreePort());
  pid_t pid = StartSkimapd(server, data);
  ASSERT_GT(pid, 0);
  // A failed assertion returns early: the server must not outlive the test.
  struct Reaper {
    pid_t* pid;
    ~Reaper() {
      if (*pid > 0 && kill(*pid, SIGKILL) == 0) waitpid(*pid, nullptr, 0);
    }
  } reaper{&pid};
  std::string out;
  ASSERT_EQ(LsWhenUp(server, &out), 0);
  const std::string model = mini + "/models/textured/obj_000001.obj";
  ASSERT_TRUE(std::filesystem::exists(model));
  EXPECT_EQ(Cli(absl::StrCat("--server=", server, " objects add ", model), &out), 1)
      << "no --object";
  const std::string bad = temp + "/not_a_model.obj";
  {
    FILE* f = std::fopen(bad.c_str(), "w");
    std::fputs("this is not a model\n", f);
    std::fclose(f);
  }
  EXPECT_EQ(Cli(absl::StrCat("--server=", server, " objects add ", bad, " --object=9"), &out), 1);
  ASSERT_EQ(Cli(absl::StrCat("--server=", server, " objects add ", model,
                             " --object=5 --name=from_model --view_azimuths=12"),
                &out),
            0)
      << out;
  EXPECT_NE(out.find("objects/5"), std::string::npos) << out;
  EXPECT_NE(out.find("from_model"), std::string::npos) << out;
  EXPECT_NE(out.find("frames   36"), std::string::npos) << out;  // 3 orbits x 12
  ASSERT_EQ(Cli(absl::StrCat("--server=", server, " objects ls"), &out), 0);
  EXPECT_EQ(out.find("objects/9"), std::string::npos) << out;
  Stop(pid);
  pid = 0;
}

}  // namespace
}  // namespace skimap::testing
