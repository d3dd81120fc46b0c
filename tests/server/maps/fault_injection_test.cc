// The disk fails at the N-th write, for every N over a session of creates, frames, pose
// updates and snapshots (real gRPC, a real SQLite file under a fault-injecting wrapper):
// the failed write answers the store's error, nothing is acknowledged without its durable
// journal record, the server goes on once writes succeed again, and a restart holds
// exactly what was acknowledged.
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <set>

#include "storage/fault_injecting_map_store.h"
#include "storage/sqlite_map_store.h"
#include "tests/common/synthetic_scene.h"
#include "tests/common/voxel_set.h"
#include "tests/server/maps/server_fixture.h"

namespace skimap::testing {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

Eigen::Isometry3d View(int i) {
  Eigen::Isometry3d pose = DefaultView();
  pose.translation().y() += 0.06 * i;
  return pose;
}

struct Server {
  std::unique_ptr<server::Server> server;
  std::unique_ptr<client::MapClient> client;
};

Server StartServer(storage::MapStore* store) {
  server::Server::Options options;
  options.grpc.address = "127.0.0.1:0";
  options.maps.worker_threads = 1;
  options.maps.snapshot_interval = absl::Hours(1);  // snapshots only when the test asks
  options.map_store = store;
  auto started = server::Server::Start(options);
  EXPECT_TRUE(started.ok()) << started.status();
  Server s{*std::move(started), nullptr};
  s.client = client::MapClient::Connect(absl::StrCat("127.0.0.1:", s.server->grpc_port()));
  return s;
}

// One session: create a carving map, 6 frames, a pose update, a snapshot, 2 frames, a pose
// update, a snapshot. Returns the frames acknowledged and the pose updates that succeeded.
struct Outcome {
  std::set<int> acked;
  std::vector<int> updated;  // indices of the pose updates that succeeded
  bool created = false;
  std::vector<absl::Status> errors;
};

v1::UpdatePosesRequest Move(int which) {
  v1::UpdatePosesRequest u;
  u.set_map("maps/m");
  for (int seq : which == 0 ? std::vector<int>{1, 3} : std::vector<int>{3, 6}) {
    v1::PoseUpdate* p = u.add_updates();
    p->set_sequence(seq);
    Eigen::Isometry3d moved = View(seq);
    moved.translation().x() += 0.05 * (which + 1);
    SetPose(moved, p->mutable_pose());
  }
  return u;
}

Outcome Session(Server& s) {
  Outcome out;
  v1::CreateMapRequest create;
  create.set_map_id("m");
  create.mutable_options()->set_resolution(0.05);
  create.mutable_options()->set_carve_free_space(true);
  absl::StatusOr<v1::Map> created = s.client->CreateMap(create);
  if (!created.ok()) {
    out.errors.push_back(created.status());
    created = s.client->CreateMap(create);  // the next write succeeds
  }
  out.created = created.ok();
  auto frame = [&](int i) {
    absl::StatusOr<v1::FrameAck> ack = s.client->IntegrateFrame(MakeFrame("maps/m", i, View(i)));
    if (ack.ok()) {
      out.acked.insert(i);
    } else {
      out.errors.push_back(ack.status());
    }
  };
  auto update = [&](int which) {
    absl::StatusOr<v1::UpdatePosesResponse> r = s.client->UpdatePoses(Move(which));
    if (r.ok()) {
      out.updated.push_back(which);
    } else {
      out.errors.push_back(r.status());
    }
  };
  for (int i = 0; i < 6; ++i) frame(i);
  update(0);
  s.server->maps().SnapshotAll();
  for (int i = 6; i < 8; ++i) frame(i);
  update(1);
  s.server->maps().SnapshotAll();
  return out;
}

TEST(FaultInjectionTest, AFailedWriteIsNeverAcknowledgedAndTheMapRecovers) {
  // Count the writes of a clean session first.
  const fs::path dir = fs::temp_directory_path() / absl::StrCat("skimap_faults_", getpid());
  fs::remove_all(dir);
  fs::create_directories(dir);
  int total_writes = 0;
  {
    storage::FaultInjectingMapStore store(
        *storage::SqliteMapStore::Open((dir / "clean.sqlite").string()));
    Server s = StartServer(&store);
    Outcome clean = Session(s);
    ASSERT_TRUE(clean.errors.empty()) << clean.errors[0];
    total_writes = store.writes();
  }
  ASSERT_GE(total_writes, 13);  // create, 8 frames, 2 updates, 2 snapshots (+ prunes)
  for (int n = 1; n <= total_writes; ++n) {
    SCOPED_TRACE(absl::StrCat("write ", n, " fails"));
    const std::string path = (dir / absl::StrCat("n", n, ".sqlite")).string();
    Outcome outcome;
    {
      storage::FaultInjectingMapStore store(*storage::SqliteMapStore::Open(path));
      const absl::Status disk_full =
          n % 2 ? absl::ResourceExhaustedError("disk full") : absl::UnavailableError("I/O error");
      store.FailWriteNumber(n, disk_full);
      Server s = StartServer(&store);
      outcome = Session(s);
      ASSERT_TRUE(outcome.created);
      // Exactly one write failed, with the store's code and message; the only other
      // error allowed is a pose update naming a frame that failed before it.
      int injected = 0;
      for (const absl::Status& e : outcome.errors) {
        if (e.code() == absl::StatusCode::kNotFound) {
          EXPECT_THAT(e.message(), HasSubstr("was never integrated")) << e;
          continue;
        }
        ++injected;
        EXPECT_EQ(e.code(), disk_full.code()) << e;
        EXPECT_THAT(e.message(), HasSubstr(disk_full.message()));
      }
      EXPECT_LE(injected, 1);
      // The server goes on: a new frame is acknowledged.
      ASSERT_TRUE(s.client->IntegrateFrame(MakeFrame("maps/m", 20, View(20))).ok());
      outcome.acked.insert(20);
    }
    // Restart on the same file, no faults: the map holds what was acknowledged, and it
    // equals a memory-only map fed exactly those frames and updates.
    auto store = storage::SqliteMapStore::Open(path);
    ASSERT_TRUE(store.ok());
    Server restarted = StartServer(store->get());
    auto info = restarted.client->GetMap("maps/m");
    ASSERT_TRUE(info.ok()) << info.status();
    EXPECT_EQ(info->stats().frames(), outcome.acked.size());
    Server reference = StartServer(nullptr);
    v1::CreateMapRequest create;
    create.set_map_id("m");
    create.mutable_options()->set_resolution(0.05);
    create.mutable_options()->set_carve_free_space(true);
    ASSERT_TRUE(reference.client->CreateMap(create).ok());
    auto feed = [&](int first, int last) {
      for (int i = first; i < last; ++i) {
        if (outcome.acked.contains(i)) {
          ASSERT_TRUE(reference.client->IntegrateFrame(MakeFrame("maps/m", i, View(i))).ok());
        }
      }
    };
    auto updated = [&](int which) {
      return std::find(outcome.updated.begin(), outcome.updated.end(), which) !=
             outcome.updated.end();
    };
    feed(0, 6);
    if (updated(0)) {
      ASSERT_TRUE(reference.client->UpdatePoses(Move(0)).ok());
    }
    feed(6, 8);
    if (updated(1)) {
      ASSERT_TRUE(reference.client->UpdatePoses(Move(1)).ok());
    }
    feed(20, 21);
    EXPECT_EQ(Voxels(*restarted.client, "maps/m"), Voxels(*reference.client, "maps/m"));
    EXPECT_EQ(info->stats().free_voxels(),
              reference.client->GetMap("maps/m")->stats().free_voxels());
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace skimap::testing
