// `skimap objects` against a real skimapd process: train one sim object from the CLI
// (frames streamed), list it, and see it again after restarting skimapd on its data dir;
// objects from their 3D models, rendered on the client or uploaded to the server.
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>

#include "absl/strings/str_cat.h"
#include "client/object_client.h"
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
  // Verification's parameters from the CLI: a value the server refuses fails the command;
  // good ones are stored with the classifier and printed.
  EXPECT_EQ(Cli(absl::StrCat("--server=", server, " objects build --top_n=65"), &out), 1);
  ASSERT_EQ(Cli(absl::StrCat("--server=", server,
                             " objects build --classes_per_object=20 --verify_threshold=180 "
                             "--top_n=2"),
                &out),
            0)
      << out;
  EXPECT_NE(out.find("verification: descriptor distance <= 180, 2 candidate classes per feature"),
            std::string::npos)
      << out;
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
  const KillOnExit reaper{&pid};
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

// `objects add MODEL --on_server`: the OBJ, its MTL and its texture are uploaded and the
// server renders and trains (AddObjectModel). A model the reader dies on (Assimp aborts on
// this PLY) fails its operation by name and nothing else; hostile names and a missing model
// file are refused by field; the uploads leave nothing behind.
TEST(ObjectsCliTest, AddOnServerRendersTheUploadedModelInAProcessOfItsOwn) {
  const std::string mini = objects::testing::MiniDataset();
  const std::string temp = objects::testing::TempDir();
  const std::string data = temp + "/data_upload";
  const std::string server = absl::StrCat("127.0.0.1:", FreePort());
  pid_t pid = StartSkimapd(server, data);
  ASSERT_GT(pid, 0);
  const KillOnExit reaper{&pid};
  std::string out;
  ASSERT_EQ(LsWhenUp(server, &out), 0);
  const std::string model = mini + "/models/textured/obj_000001.obj";
  ASSERT_EQ(Cli(absl::StrCat("--server=", server, " objects add ", model,
                             " --object=6 --on_server --view_azimuths=3"),
                &out),
            0)
      << out;
  EXPECT_NE(out.find("objects/6"), std::string::npos) << out;
  EXPECT_NE(out.find("frames    9"), std::string::npos) << out;  // 3 orbits x 3

  auto client = client::ObjectClient::Connect(server);
  v1::AddObjectModelRequest header;
  header.set_obj_id(7);
  header.set_model("abort.ply");
  const std::string hostile = temp + "/abort.ply";
  {
    std::ifstream seed(std::string(SKIMAP_FUZZ_CORPUS) + "/model_file/assimp_abort.ply",
                       std::ios::binary);
    ASSERT_TRUE(seed);
    seed.get();  // the fuzz target's control byte
    std::ofstream(hostile, std::ios::binary) << seed.rdbuf();
  }
  absl::StatusOr<v1::Operation> op = client->AddObjectModel(header, {{"abort.ply", hostile}});
  ASSERT_TRUE(op.ok()) << op.status();
  absl::StatusOr<v1::Operation> done = client->WaitDone(op->name(), nullptr);
  EXPECT_EQ(done.status().code(), absl::StatusCode::kInvalidArgument) << done.status();
  EXPECT_NE(done.status().message().find("abort.ply"), std::string::npos) << done.status();

  for (const char* name : {"../escape.ply", "/etc/passwd", "a/./b.ply", "bad name.ply", ""}) {
    header.set_model("model.ply");
    op = client->AddObjectModel(header, {{name, hostile}});
    EXPECT_EQ(op.status().code(), absl::StatusCode::kInvalidArgument) << name;
    EXPECT_NE(op.status().message().find("file.name"), std::string::npos) << op.status();
  }
  header.set_model("model.ply");
  header.mutable_views()->set_effects("clutter,fog");
  op = client->AddObjectModel(header, {{"model.ply", hostile}});
  EXPECT_EQ(op.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(op.status().message().find("views.effects"), std::string::npos) << op.status();
  header.mutable_views()->clear_effects();
  header.set_model("missing.obj");
  op = client->AddObjectModel(header, {{"abort.ply", hostile}});
  EXPECT_EQ(op.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(op.status().message().rfind("model: ", 0), 0u) << op.status();
  EXPECT_NE(op.status().message().find("missing.obj"), std::string::npos) << op.status();
  header.set_obj_id(6);  // trained above
  header.set_model(std::string(300, 'a'));
  EXPECT_EQ(client->AddObjectModel(header, {}).status().code(), absl::StatusCode::kAlreadyExists);

  ASSERT_EQ(Cli(absl::StrCat("--server=", server, " objects ls"), &out), 0);
  EXPECT_NE(out.find("objects/6"), std::string::npos) << out;
  EXPECT_EQ(out.find("objects/7"), std::string::npos) << out;
  EXPECT_TRUE(std::filesystem::is_empty(data + "/model-uploads"));
  Stop(pid);
  pid = 0;
}

}  // namespace
}  // namespace skimap::testing
