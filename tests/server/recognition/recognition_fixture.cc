#include "tests/server/recognition/recognition_fixture.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <sstream>
#include <thread>

#include "absl/strings/str_cat.h"
#include "client/cli/dataset_frames.h"
#include "client/cli/training_frames.h"
#include "client/frame_stream.h"
#include "client/object_client.h"
#include "dataset/reader.h"
#include "sim/generator.h"
#include "tests/common/test_temp_dir.h"

namespace skimap::testing {
namespace fs = std::filesystem;

namespace {

// The mini dataset (train + test), generated once per build of this test binary.
std::string MiniWithScene() {
  const fs::path root = fs::path(SKIMAP_RECOGNITION_TEST_DATA_DIR) / "mini";
  const fs::path done = root / ".complete";
  const std::string stamp =
      std::to_string(fs::last_write_time("/proc/self/exe").time_since_epoch().count());
  fs::create_directories(SKIMAP_RECOGNITION_TEST_DATA_DIR);
  const std::string lock_path = std::string(SKIMAP_RECOGNITION_TEST_DATA_DIR) + "/.lock";
  const int fd = open(lock_path.c_str(), O_CREAT | O_RDWR, 0644);
  EXPECT_GE(fd, 0);
  flock(fd, LOCK_EX);
  std::string have;
  std::getline(std::ifstream(done), have);
  if (have != stamp) {
    fs::remove_all(root);
    sim::GeneratorOptions o;
    o.out_dir = root.string();
    o.preset = "mini";
    o.threads = 2;
    absl::StatusOr<sim::GeneratorStats> s = sim::Generate(o);
    EXPECT_TRUE(s.ok()) << s.status();
    if (s.ok()) std::ofstream(done) << stamp << "\n";
  }
  flock(fd, LOCK_UN);
  close(fd);
  return root.string();
}

std::unique_ptr<server::Server> Start(const std::string& data_dir) {
  server::Server::Options o;
  o.grpc.address = "127.0.0.1:0";
  o.maps.worker_threads = 2;
  o.maps_db_path = data_dir + "/maps.sqlite";
  o.objects.db_path = data_dir + "/objects.sqlite";
  o.objects.threads = 2;
  absl::StatusOr<std::unique_ptr<server::Server>> s = server::Server::Start(o);
  EXPECT_TRUE(s.ok()) << s.status();
  return s.ok() ? *std::move(s) : nullptr;
}

void TrainObjects(RecognitionWorld& w) {
  std::unique_ptr<client::ObjectClient> c =
      client::ObjectClient::Connect(absl::StrCat("127.0.0.1:", w.server->grpc_port()));
  absl::StatusOr<std::vector<client::TrainingObject>> objects =
      client::ListTrainingObjects(w.dataset);
  ASSERT_TRUE(objects.ok()) << objects.status();
  for (const client::TrainingObject& o : *objects) {
    absl::StatusOr<dataset::Sequence> seq = dataset::LoadBopScene(o.scene_dir);
    ASSERT_TRUE(seq.ok()) << seq.status();
    v1::TrainObjectRequest header;
    header.set_obj_id(o.obj_id);
    header.set_display_name(o.name);
    header.mutable_params()->set_detector("ORB");
    size_t next = 0;
    absl::StatusOr<v1::Object> trained =
        c->TrainObject(header, [&]() -> absl::StatusOr<std::optional<v1::TrainingFrame>> {
          while (next < seq->frames.size()) {
            absl::StatusOr<std::optional<v1::TrainingFrame>> f =
                client::ToTrainingFrame(seq->frames[next++], o.obj_id);
            if (!f.ok()) return f.status();
            if (f->has_value()) return f;
          }
          return std::nullopt;
        });
    ASSERT_TRUE(trained.ok()) << trained.status();
  }
  v1::BuildClassifierRequest build;
  build.mutable_params()->set_classes_per_object(300);
  build.mutable_params()->set_trees(24);
  build.mutable_params()->set_max_depth(24);
  absl::StatusOr<v1::Operation> op = c->BuildClassifier(build);
  ASSERT_TRUE(op.ok()) << op.status();
  op = c->WaitDone(op->name(), nullptr, absl::Milliseconds(100));
  ASSERT_TRUE(op.ok()) << op.status();
}

// The world's client: calls may take minutes under a sanitizer (UpdatePoses re-keys every
// volume of the map), so the deadline is 10 minutes, not the default minute.
client::MapClient::Options ClientOptions() {
  client::MapClient::Options options;
  options.timeout = absl::Minutes(10);
  return options;
}

void StreamScene(RecognitionWorld& w) {
  v1::CreateMapRequest create;
  create.set_map_id("scene");
  create.mutable_options()->set_resolution(0.02);
  v1::RecognitionOptions* r = create.mutable_options()->mutable_recognition();
  r->set_enabled(true);
  r->set_policy(v1::RecognitionOptions::EVERY_FRAME);
  ASSERT_TRUE(w.client->CreateMap(create).ok());

  // The watcher: every event from the first on, while the scene streams.
  std::mutex mu;
  grpc::ClientContext watch_context;
  v1::WatchInstancesRequest watch;
  watch.set_map("maps/scene");
  std::unique_ptr<grpc::ClientReader<v1::InstanceEvent>> reader =
      w.client->stub().WatchInstances(&watch_context, watch);
  std::thread watcher([&] {
    v1::InstanceEvent e;
    while (reader->Read(&e)) {
      std::lock_guard<std::mutex> lock(mu);
      w.events.push_back(e);
    }
  });

  absl::StatusOr<dataset::Sequence> seq = dataset::LoadBopScene(w.scene);
  ASSERT_TRUE(seq.ok()) << seq.status();
  for (const dataset::ObjectAnnotation& a : seq->frames.front().objects) {
    w.truth.push_back({a.obj_id, seq->frames.front().T_wc * a.T_m2c});
  }
  client::FrameStream stream(&w.client->stub(), {.window = 4});
  for (const dataset::Frame& f : seq->frames) {
    absl::StatusOr<v1::Frame> frame = client::ToApiFrame(f, "maps/scene", f.id);
    ASSERT_TRUE(frame.ok()) << frame.status();
    ASSERT_TRUE(stream.Send(*frame).ok());
  }
  absl::StatusOr<std::vector<v1::FrameAck>> acks = stream.Finish();
  ASSERT_TRUE(acks.ok()) << acks.status();
  w.frames = static_cast<int>(acks->size());
  for (const v1::FrameAck& a : *acks) ASSERT_EQ(a.code(), 0) << a.message();

  // Every frame was recognised before its ack: the map's last event is final. Wait for
  // the watcher to see it, then end the watch.
  const uint64_t last = w.client->GetMap("maps/scene")->stats().instance_event_sequence();
  for (int i = 0; i < 200; ++i) {
    {
      std::lock_guard<std::mutex> lock(mu);
      if (!w.events.empty() && w.events.back().sequence() >= last) break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  watch_context.TryCancel();
  watcher.join();
}

RecognitionWorld* Build() {
  auto* w = new RecognitionWorld;
  w->dataset = MiniWithScene();
  w->scene = w->dataset + "/test/000001";
  w->data_dir = TestTempDir("skimap_recognition");
  w->server = Start(w->data_dir);
  if (w->server == nullptr) return w;
  w->client = client::MapClient::Connect(absl::StrCat("127.0.0.1:", w->server->grpc_port()),
                                         ClientOptions());
  TrainObjects(*w);
  StreamScene(*w);
  return w;
}

}  // namespace

RecognitionWorld& World() {
  static RecognitionWorld* world = Build();
  return *world;
}

void RestartWorld() {
  RecognitionWorld& w = World();
  w.client.reset();
  w.server.reset();
  w.server = Start(w.data_dir);
  ASSERT_NE(w.server, nullptr);
  w.client = client::MapClient::Connect(absl::StrCat("127.0.0.1:", w.server->grpc_port()),
                                        ClientOptions());
}

std::vector<v1::Instance> AllInstances(client::MapClient& c, const std::string& map) {
  std::vector<v1::Instance> out;
  v1::ListInstancesRequest request;
  request.set_map(map);
  request.set_page_size(2);  // several pages
  for (;;) {
    grpc::ClientContext context;
    v1::ListInstancesResponse response;
    const grpc::Status s = c.stub().ListInstances(&context, request, &response);
    EXPECT_TRUE(s.ok()) << s.error_message();
    if (!s.ok()) return out;
    out.insert(out.end(), response.instances().begin(), response.instances().end());
    if (response.next_page_token().empty()) return out;
    request.set_page_token(response.next_page_token());
  }
}

double TranslationError(const v1::Instance& i, const Eigen::Isometry3d& truth) {
  const v1::Vec3& t = i.pose().translation();
  return (Eigen::Vector3d(t.x(), t.y(), t.z()) - truth.translation()).norm();
}

double RotationErrorDeg(const v1::Instance& i, const Eigen::Isometry3d& truth) {
  const v1::Quaternion& q = i.pose().rotation();
  return Eigen::Quaterniond(q.w(), q.x(), q.y(), q.z())
             .angularDistance(Eigen::Quaterniond(truth.linear())) *
         180 / M_PI;
}

}  // namespace skimap::testing
