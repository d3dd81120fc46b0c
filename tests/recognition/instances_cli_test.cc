// `skimap instances` and `skimap stream --recognition` (client/instances_command.h), the
// real CLI binary against the recognition world's server (recognition_fixture.h).
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>

#include "Eigen/Geometry"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "tests/recognition/recognition_fixture.h"

namespace skimap::testing {
namespace {

struct CliRun {
  int exit_code = -1;
  std::string out;  // stdout and stderr
};

// Runs the skimap CLI against the world's server with `args`.
CliRun Cli(const std::string& args) {
  RecognitionWorld& w = World();
  const std::string command = absl::StrCat(
      SKIMAP_CLI_PATH, " --server=127.0.0.1:", w.server->grpc_port(), " ", args, " 2>&1");
  CliRun run;
  FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) return run;
  char buffer[4096];
  size_t n = 0;
  while ((n = fread(buffer, 1, sizeof buffer, pipe)) > 0) run.out.append(buffer, n);
  const int status = pclose(pipe);
  run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return run;
}

TEST(InstancesCliTest, JsonIsTheListingInTheBopConvention) {
  const std::vector<v1::Instance> listed = AllInstances(*World().client, "maps/scene");
  ASSERT_FALSE(listed.empty());
  const CliRun run = Cli("instances --map=scene --json");
  ASSERT_EQ(run.exit_code, 0) << run.out;
  const nlohmann::json parsed = nlohmann::json::parse(run.out);
  ASSERT_EQ(parsed.size(), listed.size());
  for (size_t k = 0; k < listed.size(); ++k) {
    const v1::Instance& i = listed[k];
    const nlohmann::json& j = parsed[k];
    EXPECT_EQ(j["id"].get<uint64_t>(), i.id());
    EXPECT_EQ(j["obj_id"].get<int>(), i.obj_id());
    EXPECT_DOUBLE_EQ(j["score"].get<double>(), i.score());
    const v1::Quaternion& q = i.pose().rotation();
    const Eigen::Matrix3d R =
        Eigen::Quaterniond(q.w(), q.x(), q.y(), q.z()).normalized().toRotationMatrix();
    ASSERT_EQ(j["R"].size(), 9u);
    for (int e = 0; e < 9; ++e) EXPECT_NEAR(j["R"][e].get<double>(), R(e / 3, e % 3), 1e-6);
    EXPECT_NEAR(j["t"][0].get<double>(), 1000 * i.pose().translation().x(), 1e-6);
    EXPECT_NEAR(j["t"][1].get<double>(), 1000 * i.pose().translation().y(), 1e-6);
    EXPECT_NEAR(j["t"][2].get<double>(), 1000 * i.pose().translation().z(), 1e-6);
  }
}

TEST(InstancesCliTest, RegionAndObjectFiltersSelectTheSameAsTheApi) {
  const std::vector<v1::Instance> all = AllInstances(*World().client, "maps/scene");
  ASSERT_FALSE(all.empty());
  // A 10 cm sphere around the first instance holds it and only what lies that close.
  const v1::Vec3& p = all.front().pose().translation();
  CliRun run = Cli(absl::StrCat("instances --map=scene --json --sphere=", p.x(), ",", p.y(), ",",
                                p.z(), ",0.1"));
  ASSERT_EQ(run.exit_code, 0) << run.out;
  std::set<uint64_t> ids;
  for (const nlohmann::json& j : nlohmann::json::parse(run.out))
    ids.insert(j["id"].get<uint64_t>());
  EXPECT_TRUE(ids.count(all.front().id()));
  for (const v1::Instance& i : all) {
    const v1::Vec3& q = i.pose().translation();
    const double d = Eigen::Vector3d(q.x() - p.x(), q.y() - p.y(), q.z() - p.z()).norm();
    EXPECT_EQ(ids.count(i.id()) == 1, d <= 0.1) << i.name();
  }
  // --objects keeps that object's instances only; the text form names each instance.
  run = Cli(absl::StrCat("instances --map=scene --objects=", all.front().obj_id()));
  ASSERT_EQ(run.exit_code, 0) << run.out;
  for (const v1::Instance& i : all) {
    EXPECT_EQ(absl::StrContains(run.out, i.name() + " "), i.obj_id() == all.front().obj_id());
  }
}

TEST(InstancesCliTest, BadFlagsAndMapsAreNamed) {
  CliRun run = Cli("instances --map=scene --box=1,2");
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_TRUE(absl::StrContains(run.out, "--box needs 6")) << run.out;
  run = Cli("instances --map=scene --sphere=0,0,x,1");
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_TRUE(absl::StrContains(run.out, "--sphere: \"x\"")) << run.out;
  run = Cli("instances --map=scene --box=0,0,0,1,1,1 --sphere=0,0,0,1");
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_TRUE(absl::StrContains(run.out, "--box and --sphere")) << run.out;
  run = Cli("instances --map=no_such_map");
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_TRUE(absl::StrContains(run.out, "NOT_FOUND")) << run.out;
  run = Cli("stream " + World().scene + " --map=cli_bad --recognition=sometimes");
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_TRUE(absl::StrContains(run.out, "--recognition")) << run.out;
  // The server is still serving the scene's map.
  EXPECT_TRUE(World().client->GetMap("maps/scene").ok());
}

TEST(InstancesCliTest, StreamWithRecognitionCreatesARecognisingMap) {
  const CliRun run =
      Cli("stream " + World().scene + " --map=cli_stream --resolution=0.02 --recognition=newest");
  ASSERT_EQ(run.exit_code, 0) << run.out;
  absl::StatusOr<v1::Map> map = World().client->GetMap("maps/cli_stream");
  ASSERT_TRUE(map.ok()) << map.status();
  EXPECT_TRUE(map->options().recognition().enabled());
  EXPECT_EQ(map->stats().frames(), static_cast<uint64_t>(World().frames));
  EXPECT_GT(map->stats().recognized_frames(), 0u);
  // Its instances are listed by the CLI (NEWEST skips frames, so the count may differ
  // from the scene's map; the command must answer, not fail).
  const CliRun listed = Cli("instances --map=cli_stream --json");
  ASSERT_EQ(listed.exit_code, 0) << listed.out;
  EXPECT_TRUE(nlohmann::json::parse(listed.out).is_array());
  ASSERT_TRUE(World().client->DeleteMap("maps/cli_stream").ok());
}

// `skimap eval` on the mini dataset's test scene with the world's trained objects: a fresh
// map recognises the scene as the world's map did (every frame, deterministic), so the 3
// objects are found and nothing else; the CSV has one row per object.
TEST(EvalCliTest, TheMiniSceneScoresEveryObjectAndWritesTheCsv) {
  RecognitionWorld& w = World();
  const std::string scene = std::filesystem::path(w.scene).filename().string();
  const std::string csv = w.data_dir + "/eval.csv";
  const CliRun run =
      Cli(absl::StrCat("eval ", w.dataset, " --scenes=", scene, " --resolution=0.02 --csv=", csv));
  ASSERT_EQ(run.exit_code, 0) << run.out;
  EXPECT_TRUE(
      absl::StrContains(run.out, absl::StrCat("| ", scene, " | 100 | 3 | 3 | 3 | 1.000 | 1.000 |")))
      << run.out;
  EXPECT_TRUE(absl::StrContains(run.out, "| all | 100 | 3 | 3 | 3 | 1.000 | 1.000 |")) << run.out;
  std::ifstream in(csv);
  std::string line;
  int rows = 0;
  std::getline(in, line);
  EXPECT_EQ(line, "scene,obj_id,instance_id,translation_error_mm,rotation_error_deg,true_positive");
  while (std::getline(in, line)) {
    ++rows;
    EXPECT_TRUE(absl::EndsWith(line, ",1")) << line;
  }
  EXPECT_EQ(rows, 3);
  // The eval map is gone; a scene the dataset lacks is named.
  EXPECT_TRUE(absl::IsNotFound(w.client->GetMap("maps/eval_" + scene).status()));
  const CliRun bad = Cli(absl::StrCat("eval ", w.dataset, " --scenes=no_such_scene"));
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_TRUE(absl::StrContains(bad.out, "--scenes: no_such_scene")) << bad.out;
}

}  // namespace
}  // namespace skimap::testing
