// Queries while frames stream in, on the MapService core (run under TSan by
// scripts/test.sh). No gRPC here: the core is where the concurrency lives (map workers,
// the snapshot lock, the registry); gRPC's own threads are not TSan-instrumented.
#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <future>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/str_cat.h"
#include "server/core/maps/map_service.h"
#include "storage/sqlite_map_store.h"
#include "tests/common/synthetic_scene.h"

namespace skimap::testing {
namespace {

TEST(MapServiceConcurrencyTest, QueriesAnswerWhileTwoStreamsFeedOneMap) {
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

// A fingerprint of the whole voxel set (centres and weights) read in one snapshot: one
// GetVoxels page holds the whole small map.
std::string VoxelSet(const server::MapService& service, const std::string& map) {
  v1::GetVoxelsRequest request;
  request.set_map(map);
  request.set_page_size(100000);
  request.set_min_voxel_weight(0);
  absl::StatusOr<v1::GetVoxelsResponse> page = service.GetVoxels(request);
  if (!page.ok() || !page->next_page_token().empty()) return "error";
  std::string out;
  for (const v1::Voxel& v : page->voxels()) {
    absl::StrAppend(&out, v.center().x(), ",", v.center().y(), ",", v.center().z(), ":", v.weight(),
                    ";");
  }
  return out;
}

const SyntheticCamera kSmall{.width = 64, .height = 48, .fx = 48, .fy = 48, .cx = 31.5, .cy = 23.5};

std::shared_ptr<const v1::Frame> SceneFrame(const std::string& map, int i) {
  Eigen::Isometry3d pose = DefaultView();
  pose.translation().y() += 0.05 * i;
  return std::make_shared<v1::Frame>(MakeFrame(map, i, pose, kSmall));
}

absl::StatusOr<v1::FrameAck> IntegrateNow(server::MapService& service,
                                          std::shared_ptr<const v1::Frame> frame) {
  std::promise<absl::StatusOr<v1::FrameAck>> done;
  service.IntegrateFrame(std::move(frame),
                         [&](absl::StatusOr<v1::FrameAck> ack) { done.set_value(std::move(ack)); });
  return done.get_future().get();
}

TEST(MapServiceConcurrencyTest, ReadersSeeTheVoxelSetOfAWholeNumberOfFrames) {
  constexpr int kFrames = 16;
  // The voxel set after each whole number of frames, from a service nobody else touches.
  std::set<std::string> whole;
  {
    server::MapService reference({.worker_threads = 1});
    v1::CreateMapRequest create;
    create.set_map_id("ref");
    ASSERT_TRUE(reference.CreateMap(create).ok());
    whole.insert(VoxelSet(reference, "maps/ref"));
    for (int i = 0; i < kFrames; ++i) {
      ASSERT_TRUE(IntegrateNow(reference, SceneFrame("maps/ref", i)).ok());
      whole.insert(VoxelSet(reference, "maps/ref"));
    }
  }
  ASSERT_EQ(whole.size(), size_t(kFrames) + 1);  // every frame changes the set

  server::MapService service({.worker_threads = 2, .queue_capacity = 8});
  v1::CreateMapRequest create;
  create.set_map_id("ref");  // the same id: the fingerprints hold voxel centres only
  ASSERT_TRUE(service.CreateMap(create).ok());
  std::atomic<bool> streaming{true};
  std::atomic<int> torn{0}, reads{0};
  auto reader = [&] {
    while (streaming.load()) {
      if (!whole.contains(VoxelSet(service, "maps/ref"))) ++torn;
      ++reads;
    }
  };
  std::thread r1(reader), r2(reader);
  // One writer with two frames in flight: the map integrates them in order.
  std::vector<std::future<absl::StatusOr<v1::FrameAck>>> acks;
  for (int i = 0; i < kFrames; ++i) {
    if (i >= 2) {
      ASSERT_TRUE(acks[i - 2].get().ok());
    }
    auto promise = std::make_shared<std::promise<absl::StatusOr<v1::FrameAck>>>();
    acks.push_back(promise->get_future());
    service.IntegrateFrame(SceneFrame("maps/ref", i),
                           [promise](absl::StatusOr<v1::FrameAck> a) { promise->set_value(a); });
  }
  for (int i = kFrames - 2; i < kFrames; ++i) ASSERT_TRUE(acks[i].get().ok());
  streaming = false;
  r1.join();
  r2.join();
  EXPECT_EQ(torn.load(), 0) << "of " << reads.load() << " reads";
  EXPECT_GT(reads.load(), 0);
  EXPECT_EQ(VoxelSet(service, "maps/ref"), VoxelSet(service, "maps/ref"));
  EXPECT_TRUE(whole.contains(VoxelSet(service, "maps/ref")));
}

TEST(MapServiceConcurrencyTest, UpdatePosesAppliesEveryCorrectionInOneSnapshot) {
  constexpr int kFrames = 8;
  server::MapService service({.worker_threads = 2, .queue_capacity = 8});
  v1::CreateMapRequest create;
  create.set_map_id("loop");
  create.mutable_options()->set_carve_free_space(true);
  ASSERT_TRUE(service.CreateMap(create).ok());
  for (int i = 0; i < kFrames; ++i)
    ASSERT_TRUE(IntegrateNow(service, SceneFrame("maps/loop", i)).ok());
  // A loop closure moving every frame, and its inverse.
  auto update = [&](double dx) {
    auto request = std::make_shared<v1::UpdatePosesRequest>();
    request->set_map("maps/loop");
    for (int i = 0; i < kFrames; ++i) {
      Eigen::Isometry3d pose = DefaultView();
      pose.translation().y() += 0.05 * i;
      pose.translation().x() += dx;
      v1::PoseUpdate* u = request->add_updates();
      u->set_sequence(i);
      SetPose(pose, u->mutable_pose());
    }
    std::promise<absl::Status> done;
    service.UpdatePoses(
        request, [&](absl::StatusOr<v1::UpdatePosesResponse> r) { done.set_value(r.status()); });
    return done.get_future().get();
  };
  const std::string before = VoxelSet(service, "maps/loop");
  ASSERT_TRUE(update(0.37).ok());
  const std::string after = VoxelSet(service, "maps/loop");
  ASSERT_NE(before, after);
  ASSERT_TRUE(update(0).ok());
  ASSERT_EQ(VoxelSet(service, "maps/loop"), before);  // exact inverse

  std::atomic<bool> running{true};
  std::atomic<int> half{0}, reads{0};
  auto reader = [&] {
    while (running.load()) {
      const std::string seen = VoxelSet(service, "maps/loop");
      if (seen != before && seen != after) ++half;
      ++reads;
    }
  };
  std::thread r1(reader), r2(reader);
  for (int round = 0; round < 6; ++round) {
    ASSERT_TRUE(update(0.37).ok());
    ASSERT_TRUE(update(0).ok());
  }
  running = false;
  r1.join();
  r2.join();
  EXPECT_EQ(half.load(), 0) << "readers saw half a loop closure in " << half.load() << " of "
                            << reads.load() << " reads";
  EXPECT_GT(reads.load(), 0);
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

// Snapshots and evictions (a 1 ms interval, a budget below one map) race two streams and
// the readers; afterwards every map equals a memory-only map fed the same frames, and a
// service reloaded from the store equals it too.
TEST(MapServiceConcurrencyTest, SnapshotsAndEvictionsRaceStreamsAndReaders) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / absl::StrCat("skimap_race_", getpid());
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  auto store = storage::SqliteMapStore::Open((dir / "maps.sqlite").string());
  ASSERT_TRUE(store.ok()) << store.status();
  const SyntheticCamera camera{
      .width = 64, .height = 48, .fx = 48, .fy = 48, .cx = 31.5, .cy = 23.5};
  constexpr int kFrames = 40;
  const std::vector<std::string> maps = {"left", "right"};
  auto frame = [&](const std::string& map, int i) {
    Eigen::Isometry3d pose = DefaultView();
    pose.translation().y() += 0.04 * i;
    return std::make_shared<v1::Frame>(MakeFrame("maps/" + map, i, pose, camera));
  };
  auto voxels = [](const server::MapService& service, const std::string& map) {
    v1::GetVoxelsRequest request;
    request.set_map("maps/" + map);
    request.set_page_size(100000);
    request.set_min_voxel_weight(0);
    auto page = service.GetVoxels(request);
    EXPECT_TRUE(page.ok()) << page.status();
    return page.ok() ? page->SerializeAsString() : "";
  };
  {
    server::MapService service({.worker_threads = 2,
                                .store = store->get(),
                                .memory_budget_bytes = 1,
                                .snapshot_interval = absl::Milliseconds(1),
                                .snapshot_records = 1});
    ASSERT_TRUE(service.Recover().ok());
    for (const std::string& m : maps) {
      v1::CreateMapRequest create;
      create.set_map_id(m);
      create.mutable_options()->set_carve_free_space(true);
      ASSERT_TRUE(service.CreateMap(create).ok());
    }
    std::atomic<bool> streaming{true};
    std::atomic<int> errors{0}, unloaded_seen{0};
    auto reader = [&] {
      while (streaming.load()) {
        auto listed = service.ListMaps(v1::ListMapsRequest());
        if (!listed.ok()) ++errors;
        for (const v1::Map& m : listed->maps()) unloaded_seen += m.stats().loaded() ? 0 : 1;
        for (const std::string& m : maps) {
          v1::GetOccupancyGridRequest grid;
          grid.set_map("maps/" + m);
          if (!service.GetOccupancyGrid(grid).ok()) ++errors;
        }
      }
    };
    auto writer = [&](const std::string& m) {
      for (int i = 0; i < kFrames; ++i) {
        for (int attempt = 0;; ++attempt) {
          std::promise<absl::StatusOr<v1::FrameAck>> done;
          service.IntegrateFrame(frame(m, i),
                                 [&](absl::StatusOr<v1::FrameAck> a) { done.set_value(a); });
          absl::StatusOr<v1::FrameAck> ack = done.get_future().get();
          if (ack.ok()) break;
          // Unavailable while the map leaves memory; the retry reaches its reloaded copy.
          if (!absl::IsUnavailable(ack.status()) || attempt > 1000) {
            ADD_FAILURE() << ack.status();
            break;
          }
          std::this_thread::sleep_for(std::chrono::milliseconds(1));
        }
      }
    };
    std::thread r(reader), w1(writer, maps[0]), w2(writer, maps[1]);
    w1.join();
    w2.join();
    streaming = false;
    r.join();
    EXPECT_EQ(errors.load(), 0);
    EXPECT_GT(unloaded_seen.load(), 0) << "no eviction happened during the streams";
    server::MapService reference({.worker_threads = 1});
    for (const std::string& m : maps) {
      v1::CreateMapRequest create;
      create.set_map_id(m);
      create.mutable_options()->set_carve_free_space(true);
      ASSERT_TRUE(reference.CreateMap(create).ok());
      for (int i = 0; i < kFrames; ++i) {
        std::promise<absl::StatusOr<v1::FrameAck>> done;
        reference.IntegrateFrame(frame(m, i),
                                 [&](absl::StatusOr<v1::FrameAck> a) { done.set_value(a); });
        ASSERT_TRUE(done.get_future().get().ok());
      }
      EXPECT_TRUE(voxels(service, m) == voxels(reference, m)) << m;
    }
    server::MapService reloaded({.worker_threads = 1, .store = store->get()});
    ASSERT_TRUE(reloaded.Recover().ok());
    for (const std::string& m : maps) EXPECT_TRUE(voxels(reloaded, m) == voxels(reference, m)) << m;
  }
  store->reset();
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace skimap::testing
