// The write path's documented limits and guarantees, over real gRPC: a full write queue,
// the in-flight bound of StreamFrames, frames no longer kept for UpdatePoses, and
// all-or-nothing pose updates.
#include <future>
#include <thread>

#include "tests/common/synthetic_scene.h"
#include "tests/server/maps/server_fixture.h"

namespace skimap::testing {
namespace {

using ::testing::HasSubstr;

// A 640 x 480 view of the synthetic scene: slow enough to integrate at 1 cm that frames
// pile up behind each other.
const SyntheticCamera kVga{
    .width = 640, .height = 480, .fx = 480, .fy = 480, .cx = 319.5, .cy = 239.5};

class WritePathTest : public ::testing::Test {
 protected:
  void Start(server::Server::Options options) {
    options.grpc.address = "127.0.0.1:0";
    options.maps.worker_threads = 1;
    auto server = server::Server::Start(options);
    ASSERT_TRUE(server.ok()) << server.status();
    server_ = *std::move(server);
    client_ = client::MapClient::Connect(absl::StrCat("127.0.0.1:", server_->grpc_port()));
  }
  void CreateMap(const std::string& id, double resolution) {
    v1::CreateMapRequest request;
    request.set_map_id(id);
    request.mutable_options()->set_resolution(resolution);
    ASSERT_TRUE(client_->CreateMap(request).ok());
  }
  std::vector<std::tuple<double, double, double, float>> Voxels(const std::string& map) {
    v1::GetVoxelsRequest request;
    request.set_map(map);
    auto voxels = client_->GetAllVoxels(request);
    EXPECT_TRUE(voxels.ok()) << voxels.status();
    std::vector<std::tuple<double, double, double, float>> out;
    for (const v1::Voxel& v : voxels.value_or(std::vector<v1::Voxel>{})) {
      out.emplace_back(v.center().x(), v.center().y(), v.center().z(), v.weight());
    }
    return out;
  }
  uint64_t Frames(const std::string& map) { return client_->GetMap(map)->stats().frames(); }

  // Streams `count` frames as fast as the client can write them (acks read on another
  // thread, never waited for) and returns the acks' codes.
  std::vector<int> Flood(const std::string& map, int count) {
    grpc::ClientContext ctx;
    auto call = client_->stub().StreamFrames(&ctx);
    std::vector<int> codes;
    std::thread reader([&] {
      v1::FrameAck ack;
      while (call->Read(&ack)) codes.push_back(ack.code());
    });
    v1::Frame frame = MakeFrame(map, 0, DefaultView(), kVga);  // rendered once: write fast
    for (int i = 0; i < count; ++i) {
      frame.set_sequence(i);
      EXPECT_TRUE(call->Write(frame));
    }
    call->WritesDone();
    reader.join();
    EXPECT_TRUE(call->Finish().ok());
    return codes;
  }

  std::unique_ptr<server::Server> server_;
  std::unique_ptr<client::MapClient> client_;
};

TEST_F(WritePathTest, AFullWriteQueueAnswersResourceExhausted) {
  server::Server::Options options;
  options.maps.queue_capacity = 1;
  Start(options);
  CreateMap("busy", 0.01);
  constexpr int kClients = 12;
  const v1::Frame frame = MakeFrame("maps/busy", 0, DefaultView(), kVga);
  std::vector<std::future<absl::StatusOr<v1::FrameAck>>> answers;
  for (int i = 0; i < kClients; ++i) {
    answers.push_back(std::async(std::launch::async, [&, i] {
      v1::Frame f = frame;
      f.set_sequence(i);
      return client_->IntegrateFrame(f);
    }));
  }
  int ok = 0, full = 0;
  for (auto& a : answers) {
    absl::StatusOr<v1::FrameAck> ack = a.get();
    if (ack.ok()) {
      ++ok;
    } else {
      EXPECT_EQ(ack.status().code(), absl::StatusCode::kResourceExhausted) << ack.status();
      EXPECT_THAT(ack.status().message(), HasSubstr("write queue full"));
      ++full;
    }
  }
  EXPECT_GT(full, 0);
  EXPECT_GT(ok, 0);
  EXPECT_EQ(Frames("maps/busy"), uint64_t(ok));  // a refused frame left no trace
}

TEST_F(WritePathTest, MaxInFlightBoundsTheFramesAStreamQueues) {
  // The queue holds as many frames as a stream may have in flight: a client that writes
  // without waiting never overflows it, because the server stops reading at the bound.
  server::Server::Options bounded;
  bounded.maps.queue_capacity = 3;
  bounded.grpc.map_service.max_in_flight = 3;
  Start(bounded);
  CreateMap("flood", 0.01);
  const std::vector<int> codes = Flood("maps/flood", 30);
  EXPECT_EQ(codes, std::vector<int>(30, 0));
  EXPECT_EQ(Frames("maps/flood"), 30u);
  server_->Shutdown();

  // The same flood with more in flight than the queue holds does overflow it: the bound
  // above is what kept it safe.
  server::Server::Options loose;
  loose.maps.queue_capacity = 1;
  loose.grpc.map_service.max_in_flight = 16;
  Start(loose);
  CreateMap("flood", 0.01);
  const std::vector<int> loose_codes = Flood("maps/flood", 30);
  EXPECT_GT(
      std::count(loose_codes.begin(), loose_codes.end(), int(absl::StatusCode::kResourceExhausted)),
      0);
}

TEST_F(WritePathTest, UpdatePosesOnAFrameNoLongerKeptIsFailedPrecondition) {
  server::Server::Options options;
  // 160 x 120 raw frames are 38 400 bytes of depth: only the newest one is kept.
  options.maps.max_kept_frame_bytes = 50000;
  Start(options);
  CreateMap("short", 0.05);
  for (int i = 0; i < 3; ++i) {
    ASSERT_TRUE(client_->IntegrateFrame(MakeFrame("maps/short", i, DefaultView())).ok());
  }
  v1::UpdatePosesRequest request;
  request.set_map("maps/short");
  v1::PoseUpdate* u = request.add_updates();
  u->set_sequence(0);
  SetPose(DefaultView(), u->mutable_pose());
  auto r = client_->UpdatePoses(request);
  EXPECT_EQ(r.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(r.status().message(), HasSubstr("updates[0].sequence"));
  EXPECT_THAT(r.status().message(), HasSubstr("no longer kept"));
  u->set_sequence(2);  // the newest is kept
  EXPECT_TRUE(client_->UpdatePoses(request).ok());
}

TEST_F(WritePathTest, AMixedValidAndInvalidUpdatePosesLeavesTheMapUntouched) {
  Start({});
  CreateMap("loop", 0.05);
  for (int i = 0; i < 3; ++i) {
    Eigen::Isometry3d pose = DefaultView();
    pose.translation().y() += 0.1 * i;
    ASSERT_TRUE(client_->IntegrateFrame(MakeFrame("maps/loop", i, pose)).ok());
  }
  const auto before = Voxels("maps/loop");
  Eigen::Isometry3d moved = DefaultView();
  moved.translation().x() += 0.3;
  auto request_with = [&](std::function<void(v1::PoseUpdate*)> second) {
    v1::UpdatePosesRequest request;
    request.set_map("maps/loop");
    v1::PoseUpdate* good = request.add_updates();
    good->set_sequence(1);
    SetPose(moved, good->mutable_pose());
    second(request.add_updates());
    return request;
  };
  struct Bad {
    std::function<void(v1::PoseUpdate*)> make;
    absl::StatusCode code;
    const char* field;
  };
  const std::vector<Bad> bad = {
      {[&](v1::PoseUpdate* u) {
         u->set_sequence(2);
         SetPose(moved, u->mutable_pose());
         u->mutable_pose()->mutable_translation()->set_x(std::nan(""));
       },
       absl::StatusCode::kInvalidArgument, "updates[1].pose.translation"},
      {[&](v1::PoseUpdate* u) {
         u->set_sequence(77);
         SetPose(moved, u->mutable_pose());
       },
       absl::StatusCode::kNotFound, "updates[1].sequence"},
      {[&](v1::PoseUpdate* u) {
         u->set_sequence(1);
         SetPose(moved, u->mutable_pose());
       },
       absl::StatusCode::kInvalidArgument, "appears twice"},
  };
  for (const Bad& b : bad) {
    auto r = client_->UpdatePoses(request_with(b.make));
    EXPECT_EQ(r.status().code(), b.code) << r.status();
    EXPECT_THAT(r.status().message(), HasSubstr(b.field));
    EXPECT_EQ(Voxels("maps/loop"), before);
  }
  // The valid half alone does change the map.
  v1::UpdatePosesRequest valid = request_with([&](v1::PoseUpdate* u) {
    u->set_sequence(0);
    SetPose(DefaultView(), u->mutable_pose());
  });
  ASSERT_TRUE(client_->UpdatePoses(valid).ok());
  EXPECT_NE(Voxels("maps/loop"), before);
}

}  // namespace
}  // namespace skimap::testing
