// Persistence through a real skimapd process: every acknowledged frame and pose update is
// in the map after kill -9 and a restart, voxel by voxel; deleted maps stay deleted.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <set>
#include <tuple>

#include "client/map_client.h"
#include "tests/common/skimapd_process.h"
#include "tests/common/synthetic_scene.h"
#include "tests/common/voxel_set.h"

namespace skimap::testing {
namespace {

Eigen::Isometry3d StepView(int i) {
  Eigen::Isometry3d pose = DefaultView();
  pose.translation().y() += 0.07 * i;
  return pose;
}

TEST(RestartTest, AcknowledgedFramesAndPoseUpdatesSurviveKillNine) {
  SkimapdProcess server(SKIMAPD_PATH, {"--worker_threads=1"});
  ASSERT_TRUE(server.Start().ok());
  auto client = client::MapClient::Connect(server.address());
  v1::CreateMapRequest create;
  create.set_map_id("kept");
  create.mutable_options()->set_resolution(0.04);
  create.mutable_options()->set_carve_free_space(true);
  ASSERT_TRUE(client->CreateMap(create).ok());
  create.set_map_id("dropped");
  ASSERT_TRUE(client->CreateMap(create).ok());
  std::unique_ptr<client::FrameStream> stream = client->OpenFrameStream({.window = 4});
  for (int i = 0; i < 6; ++i)
    ASSERT_TRUE(stream->Send(MakeFrame("maps/kept", i, StepView(i))).ok());
  auto acks = stream->Finish();
  ASSERT_TRUE(acks.ok());
  for (const v1::FrameAck& a : *acks) ASSERT_EQ(a.code(), 0) << a.message();
  v1::UpdatePosesRequest update;
  update.set_map("maps/kept");
  for (int i : {1, 4}) {
    v1::PoseUpdate* u = update.add_updates();
    u->set_sequence(i);
    Eigen::Isometry3d moved = StepView(i);
    moved.translation().x() += 0.11;
    SetPose(moved, u->mutable_pose());
  }
  ASSERT_TRUE(client->UpdatePoses(update).ok());
  ASSERT_TRUE(client->DeleteMap("maps/dropped").ok());
  const VoxelSet before = Voxels(*client, "maps/kept");
  const v1::Map info = *client->GetMap("maps/kept");
  ASSERT_GT(before.size(), 500u);
  EXPECT_TRUE(info.stats().persistent());
  EXPECT_EQ(info.stats().journal_position(), 7u);  // 6 frames and one pose update

  ASSERT_TRUE(server.CrashAndRestart().ok());
  client = client::MapClient::Connect(server.address());
  EXPECT_EQ(Voxels(*client, "maps/kept"), before);
  const v1::Map after = *client->GetMap("maps/kept");
  EXPECT_EQ(after.stats().frames(), 6u);
  EXPECT_EQ(after.stats().journal_position(), 7u);
  EXPECT_EQ(after.stats().free_voxels(), info.stats().free_voxels());
  EXPECT_DOUBLE_EQ(after.options().resolution(), 0.04);
  EXPECT_EQ(client->GetMap("maps/dropped").status().code(), absl::StatusCode::kNotFound);
  // The map goes on: a known sequence is still refused, a new one integrates, a pose
  // update still reaches a frame from before the restart.
  EXPECT_EQ(client->IntegrateFrame(MakeFrame("maps/kept", 2, StepView(2))).status().code(),
            absl::StatusCode::kAlreadyExists);
  EXPECT_TRUE(client->IntegrateFrame(MakeFrame("maps/kept", 6, StepView(6))).ok());
  EXPECT_TRUE(client->UpdatePoses(update).ok());
  const VoxelSet later = Voxels(*client, "maps/kept");
  ASSERT_TRUE(server.CrashAndRestart().ok());
  client = client::MapClient::Connect(server.address());
  EXPECT_EQ(Voxels(*client, "maps/kept"), later);
}

}  // namespace
}  // namespace skimap::testing
