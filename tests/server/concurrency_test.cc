// Queries while frames stream in, on the MapService core (run under TSan by
// scripts/test.sh). No gRPC here: the core is where the concurrency lives (map workers,
// the snapshot lock, the registry); gRPC's own threads are not TSan-instrumented.
#include <gtest/gtest.h>

#include <atomic>
#include <future>
#include <thread>
#include <vector>

#include "server/map_service.h"
#include "tests/server/synthetic_scene.h"

namespace skimap::testing {
namespace {

TEST(MapServiceConcurrencyTest, QueriesSeeWholeFramesWhileFramesStreamIn) {
  server::MapService service({.worker_threads = 2, .queue_capacity = 8});
  v1::CreateMapRequest create;
  create.set_map_id("busy");
  create.mutable_options()->set_carve_free_space(true);  // the free volume is read and written too
  ASSERT_TRUE(service.CreateMap(create).ok());
  const SyntheticCamera camera{
      .width = 64, .height = 48, .fx = 48, .fy = 48, .cx = 31.5, .cy = 23.5};
  constexpr int kFrames = 24;
  std::vector<std::shared_ptr<const v1::Frame>> frames;
  for (int i = 0; i < kFrames; ++i) {
    Eigen::Isometry3d pose = DefaultView();
    pose.translation().y() += 0.05 * i;
    frames.push_back(std::make_shared<v1::Frame>(MakeFrame("maps/busy", i, pose, camera)));
  }

  std::atomic<bool> streaming{true};
  std::atomic<int> query_errors{0}, grids{0};
  auto reader = [&] {
    uint64_t last_frames = 0;
    while (streaming.load()) {
      v1::GetOccupancyGridRequest grid_request;
      grid_request.set_map("maps/busy");
      auto grid = service.GetOccupancyGrid(grid_request);
      if (!grid.ok() || grid->frames() < last_frames) ++query_errors;
      if (grid.ok()) last_frames = grid->frames();
      ++grids;
      v1::RadiusSearchRequest search;
      search.set_map("maps/busy");
      search.mutable_center()->set_x(0.5);
      search.set_radius(0.5);
      if (!service.RadiusSearch(search).ok()) ++query_errors;
      v1::GetVoxelsRequest voxels;
      voxels.set_map("maps/busy");
      voxels.set_page_size(50);
      if (!service.GetVoxels(voxels).ok()) ++query_errors;
      v1::GetMapRequest info;
      info.set_name("maps/busy");
      if (!service.GetMap(info).ok()) ++query_errors;
    }
  };
  std::thread r1(reader), r2(reader);

  // Two "streams" feeding the same map, each with at most 2 frames in flight.
  std::atomic<int> ok{0}, failed{0};
  auto writer = [&](int first) {
    for (int i = first; i < kFrames; i += 2) {
      std::promise<void> done;  // not absl::Notification: TSan must see the hand-off
      service.IntegrateFrame(frames[i], [&](absl::StatusOr<v1::FrameAck> ack) {
        ack.ok() ? ++ok : ++failed;
        done.set_value();
      });
      done.get_future().wait();
    }
  };
  std::thread w1(writer, 0), w2(writer, 1);
  w1.join();
  w2.join();
  streaming = false;
  r1.join();
  r2.join();
  EXPECT_EQ(ok.load(), kFrames);
  EXPECT_EQ(failed.load(), 0);
  EXPECT_EQ(query_errors.load(), 0);
  EXPECT_GT(grids.load(), 0);
  v1::GetMapRequest info;
  info.set_name("maps/busy");
  EXPECT_EQ(service.GetMap(info)->stats().frames(), uint64_t(kFrames));
}

TEST(MapServiceConcurrencyTest, DeleteWhileFramesAreQueuedAnswersEveryFrame) {
  server::MapService service({.worker_threads = 1, .queue_capacity = 16});
  v1::CreateMapRequest create;
  create.set_map_id("doomed");
  ASSERT_TRUE(service.CreateMap(create).ok());
  auto frame = std::make_shared<v1::Frame>(MakeFrame("maps/doomed", 0, DefaultView()));
  std::atomic<int> answered{0};
  for (int i = 0; i < 8; ++i) {
    auto f = std::make_shared<v1::Frame>(*frame);
    f->set_sequence(i);
    service.IntegrateFrame(f, [&](absl::StatusOr<v1::FrameAck>) { ++answered; });
  }
  v1::DeleteMapRequest del;
  del.set_name("maps/doomed");
  ASSERT_TRUE(service.DeleteMap(del).ok());  // the last reference: drains the queue
  EXPECT_EQ(answered.load(), 8);
}

}  // namespace
}  // namespace skimap::testing
