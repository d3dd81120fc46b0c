// skimap-ros when skimapd misbehaves or the node is misconfigured, against real components
// (bridge_fixture.h): a stalled skimapd makes the bridge drop and count frames, never queue;
// a restarted one gets a new stream; a hung one does not hold the node's shutdown; a bad
// parameter stops the node with its name.
#include "tests/ros/bridge_fixture.h"

namespace skimap::testing {
namespace {

// skimapd stalls (SIGSTOP): the camera keeps publishing, the bridge keeps a bounded queue
// and drops the rest, counted; once skimapd resumes, what was in flight or queued is
// acknowledged and the map holds exactly the acknowledged frames.
TEST_F(BridgeTest, AStalledServerMakesTheBridgeDropAndCountNotQueue) {
  ros::NodeHandle nh;
  StartBridge("stall", {"_queue_frames:=2", "_window:=4"});
  CycleFramesTo(30);
  PublishFrames(nh, {}, false, [&] { server_.Signal(SIGSTOP); });
  ros::WallDuration(1.0).sleep();
  server_.Signal(SIGCONT);
  ros::WallDuration(3.0).sleep();
  EXPECT_EQ(StopBridge(), 0) << BridgeLog();
  const std::string json = StatsJson();
  const auto number = [&](const std::string& key) {
    const size_t at = json.find("\"" + key + "\": ");
    return at == std::string::npos ? -1 : std::atoi(json.c_str() + at + key.size() + 4);
  };
  EXPECT_EQ(number("offered"), 30) << json;
  // At most the window, the queue and the frame the sender holds get through.
  EXPECT_GE(number("dropped"), 30 - 4 - 2 - 1) << json;
  EXPECT_EQ(number("acked") + number("dropped"), 30) << json;
  EXPECT_EQ(Frames("stall"), uint64_t(number("acked")));
}

// skimapd dies (kill -9) and comes back on the same port: the bridge reopens its stream
// and the frames after the restart are acknowledged; those in flight at the crash are
// counted as lost, never acknowledged.
TEST_F(BridgeTest, TheBridgeReconnectsAfterSkimapdRestarts) {
  const int port = FreePort();
  const std::string address = absl::StrCat("127.0.0.1:", port);
  const std::string data = (dir_ / "own").string();
  const auto start = [&] {
    return SpawnProcess({SKIMAPD_PATH, "--address=" + address, "--data_dir=" + data,
                         "--http_address=", "--worker_threads=1"});
  };
  pid_t own = start();
  const KillOnExit reaper{&own};
  auto own_client = client::MapClient::Connect(address);
  ASSERT_TRUE(own_client->WaitForServer(absl::Seconds(20)).ok());
  ros::NodeHandle nh;
  server_override_ = address;
  StartBridge("again");
  const std::vector<MmFrame> all = frames_;
  frames_.assign(all.begin(), all.begin() + 5);
  PublishFrames(nh);
  const auto frames = [&] {
    auto m = own_client->GetMap("maps/again");
    return m.ok() ? m->stats().frames() : 0;
  };
  ASSERT_TRUE(WaitFor([&] { return frames() == 5; }, 30)) << BridgeLog();
  kill(own, SIGKILL);
  waitpid(own, nullptr, 0);
  own = start();
  ASSERT_TRUE(own_client->WaitForServer(absl::Seconds(20)).ok());
  // The journal kept every acknowledged frame.
  ASSERT_TRUE(WaitFor([&] { return frames() == 5; }, 20));
  frames_.assign(all.begin() + 5, all.end());
  // The first frames after the crash may go to the dead stream (lost) before the bridge
  // notices; publish until frames after the restart are acknowledged.
  for (int round = 0; round < 5 && frames() < 6; ++round) {
    PublishFrames(nh);
    WaitFor([&] { return frames() >= 6; }, 3);
  }
  EXPECT_GE(frames(), 6u) << BridgeLog();
  EXPECT_EQ(StopBridge(), 0) << BridgeLog();
  const std::string stats = StatsJson();
  EXPECT_NE(stats.find("\"acked\": "), std::string::npos);
  kill(own, SIGTERM);
  waitpid(own, nullptr, 0);
  own = 0;
}

TEST_F(BridgeTest, ABadParameterStopsTheBridgeWithItsName) {
  for (const auto& [arg, message] : std::vector<std::pair<std::string, std::string>>{
           {"_depth_encoding:=jpeg", "~depth_encoding: \"jpeg\""},
           {"_shutdown_timeout:=0.0", "~shutdown_timeout: 0 must be a finite number > 0"}}) {
    StartBridge("bad", {arg});
    int status = -1;
    waitpid(bridge_, &status, 0);
    bridge_ = -1;
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 1) << arg;
    EXPECT_NE(BridgeLog().find(message), std::string::npos) << BridgeLog();
  }
}

// skimapd stops reading for good (SIGSTOP, a hung host) while frames are in flight: SIGINT
// still ends the node, after its wait for the acks (10 s) and ~shutdown_timeout for the
// stream, with status 2 and its report written.
TEST_F(BridgeTest, AHungSkimapdDoesNotHoldTheNodesShutdown) {
  ros::NodeHandle nh;
  StartBridge("hung", {"_queue_frames:=2", "_window:=4", "_shutdown_timeout:=2.0"});
  CycleFramesTo(30);
  PublishFrames(nh, {}, false, [&] { server_.Signal(SIGSTOP); });
  ros::WallDuration(1.0).sleep();
  const auto start = std::chrono::steady_clock::now();
  const int status = StopBridge();
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  server_.Signal(SIGCONT);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 2) << status << BridgeLog();
  EXPECT_LT(seconds, 10 + 2 + 10) << BridgeLog();
  EXPECT_NE(BridgeLog().find("did not release the stream within 2.0 s"), std::string::npos)
      << BridgeLog();
  const std::string stats = StatsJson();
  EXPECT_NE(stats.find("\"offered\": 30"), std::string::npos) << stats;
}

}  // namespace
}  // namespace skimap::testing
