// recognition_bench: the online recognition pipeline (issue 11; docs/recognition.md) run
// in-process on a BOP dataset's test scenes: frames/s of mapping + recognition, mapping
// frames/s with recognition off (the same frames), and a quick score of the final
// instances (3 cm / 10 degrees, one-to-one, no symmetries; `skimap eval` is the full
// evaluation). Markdown on stdout, progress on stderr.
//
//   build/bench/bench/recognition_bench --dataset=data/sk [--detector=ORB] [--db=FILE]
//       [--scenes=000001,000002] [--every=1] [--resolution=0.02] [--max_frames=0]
//
// The object database is trained from the dataset's train split (TrainObjectDatabase) and
// cached in --db. Frames are sent as the dataset stores them (16-bit PNG depth, PNG or
// JPEG colour: client/cli/dataset_frames.h), 8 in flight, policy EVERY_FRAME (every frame is
// recognised; its ack waits for it), so frames/s is the whole pipeline's.
//
// Mapping throughput (--mapping_only): the scene is streamed with recognition off and with
// policy NEWEST, alternately, --repeats times; each figure is the median. Every run must
// build the same RGB volume (its voxel count is checked). A third run,
// recognition off beside a busy loop at idle priority (SCHED_IDLE: it only gets a core
// the pipeline leaves), is the control: what any other work on this machine's other core
// costs mapping, whatever its priority.
#include <sched.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <filesystem>
#include <initializer_list>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "absl/flags/flag.h"
#include "absl/flags/parse.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "bench/samples.h"
#include "client/cli/dataset_frames.h"
#include "dataset/reader.h"
#include "perception/objects/training.h"
#include "perception/recognition/instance_estimator.h"
#include "server/core/maps/map_service.h"
#include "server/core/objects/object_database_io.h"
#include "server/core/recognition/instance_queries.h"

ABSL_FLAG(std::string, dataset, "", "BOP dataset root (train/ and test/ splits)");
ABSL_FLAG(std::string, detector, "ORB", "feature detector of the object database");
ABSL_FLAG(std::string, db, "", "object database cache (SQLite); trained and written if missing");
ABSL_FLAG(std::string, scenes, "", "test scene folder names, comma-separated; empty: all");
ABSL_FLAG(int, every, 1, "stream every n-th frame (fewer vantage points)");
ABSL_FLAG(double, resolution, 0.02, "map resolution, metres");
ABSL_FLAG(int, max_frames, 0, "frames per scene at most (0: all)");
ABSL_FLAG(int, classes, 100, "classes per object (k)");
ABSL_FLAG(double, db_resolution, 0.01, "descriptor voxel edge of the object database, metres");
ABSL_FLAG(int, max_features, 1000, "features per image of the object database");
ABSL_FLAG(bool, mapping_only, true,
          "also stream each scene with recognition off, and with policy NEWEST (mapping "
          "throughput with recognition on)");
ABSL_FLAG(int, repeats, 3, "mapping throughput: off / NEWEST / control runs per scene (median)");
ABSL_FLAG(double, sphere_distance, 0, "active sphere distance (0 = scene rule)");
ABSL_FLAG(double, sphere_radius, 0.6, "active sphere radius");
ABSL_FLAG(double, min_fit, -1, "the map's min_instance_fit (-1: the server's default)");
ABSL_FLAG(double, labels_resolution, 0, "labels voxel edge, metres (0: the server's default)");
ABSL_FLAG(int, triples, 0, "RANSAC triples per object and frame (0: the server's default)");

namespace skimap::bench {
namespace {

namespace v1 = skimap::v1;

[[noreturn]] void Die(const std::string& what) {
  std::fprintf(stderr, "recognition_bench: %s\n", what.c_str());
  std::exit(1);
}

std::shared_ptr<const objects::ObjectDatabase> Database(const std::string& root) {
  const std::string cache = absl::GetFlag(FLAGS_db);
  if (!cache.empty() && std::filesystem::exists(cache)) {
    absl::StatusOr<objects::ObjectDatabase> db = objects::LoadObjectDatabase(cache);
    if (!db.ok()) Die(db.status().ToString());
    std::fprintf(stderr, "object database from %s\n", cache.c_str());
    return std::make_shared<const objects::ObjectDatabase>(*std::move(db));
  }
  objects::ObjectDatabaseParams params;
  params.features.detector = absl::GetFlag(FLAGS_detector);
  params.classes_per_object = absl::GetFlag(FLAGS_classes);
  params.resolution = absl::GetFlag(FLAGS_db_resolution);
  params.features.max_features = absl::GetFlag(FLAGS_max_features);
  std::fprintf(stderr, "training the object database (%s) ...\n", params.features.detector.c_str());
  const Clock::time_point t0 = Clock::now();
  absl::StatusOr<objects::ObjectDatabase> db = objects::TrainObjectDatabase(root, params);
  if (!db.ok()) Die(db.status().ToString());
  std::fprintf(stderr, "trained in %.1f s\n",
               std::chrono::duration<double>(Clock::now() - t0).count());
  if (!cache.empty()) {
    if (absl::Status s = objects::SaveObjectDatabase(*db, cache); !s.ok()) Die(s.ToString());
  }
  return std::make_shared<const objects::ObjectDatabase>(*std::move(db));
}

struct Run {
  double seconds = 0;
  int frames = 0;
  v1::MapStats stats;
  std::vector<v1::Instance> instances;
};

enum class Mode { kOff, kNewest, kEveryFrame };

// A thread spinning at idle priority for its lifetime (the control run's other work).
class IdleSpinner {
 public:
  IdleSpinner()
      : thread_([this] {
          sched_param p{};
          if (sched_setscheduler(0, SCHED_IDLE, &p) != 0) Die("sched_setscheduler(SCHED_IDLE)");
          volatile uint64_t x = 0;
          while (!stop_.load(std::memory_order_relaxed)) x = x + 1;
        }) {}
  ~IdleSpinner() {
    stop_ = true;
    thread_.join();
  }

 private:
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

Run Stream(std::shared_ptr<const objects::ObjectDatabase> db,
           const std::vector<dataset::Frame>& frames, Mode mode) {
  const bool recognition = mode != Mode::kOff;
  server::MapService::Options o;
  o.classifier = [db] { return db; };
  server::MapService service(o);
  v1::CreateMapRequest create;
  create.set_map_id("scene");
  create.mutable_options()->set_resolution(absl::GetFlag(FLAGS_resolution));
  if (recognition) {
    v1::RecognitionOptions* r = create.mutable_options()->mutable_recognition();
    r->set_enabled(true);
    r->set_policy(mode == Mode::kEveryFrame ? v1::RecognitionOptions::EVERY_FRAME
                                            : v1::RecognitionOptions::NEWEST);
    r->set_sphere_distance(absl::GetFlag(FLAGS_sphere_distance));
    r->set_sphere_radius(absl::GetFlag(FLAGS_sphere_radius));
    if (absl::GetFlag(FLAGS_min_fit) >= 0) r->set_min_instance_fit(absl::GetFlag(FLAGS_min_fit));
    if (absl::GetFlag(FLAGS_labels_resolution) > 0) {
      r->set_labels_resolution(absl::GetFlag(FLAGS_labels_resolution));
    }
    if (absl::GetFlag(FLAGS_triples) > 0) r->set_triples(absl::GetFlag(FLAGS_triples));
  }
  if (auto m = service.CreateMap(create); !m.ok()) Die(m.status().ToString());
  // Frames are read and encoded up front: only the server's work is timed.
  std::vector<std::shared_ptr<v1::Frame>> api;
  for (size_t i = 0; i < frames.size(); ++i) {
    absl::StatusOr<v1::Frame> f = client::ToApiFrame(frames[i], "maps/scene", frames[i].id);
    if (!f.ok()) Die(f.status().ToString());
    api.push_back(std::make_shared<v1::Frame>(*std::move(f)));
  }
  std::mutex mu;
  std::condition_variable cv;
  int in_flight = 0, done = 0;
  std::string error;
  const Clock::time_point t0 = Clock::now();
  for (const auto& f : api) {
    {
      std::unique_lock<std::mutex> lock(mu);
      cv.wait(lock, [&] { return in_flight < 8; });
      ++in_flight;
    }
    service.IntegrateFrame(f, [&](absl::StatusOr<v1::FrameAck> ack) {
      std::lock_guard<std::mutex> lock(mu);
      --in_flight;
      ++done;
      if (!ack.ok() && error.empty()) error = ack.status().ToString();
      cv.notify_all();
    });
  }
  std::unique_lock<std::mutex> lock(mu);
  cv.wait(lock, [&] { return done == static_cast<int>(api.size()); });
  lock.unlock();
  Run run;
  run.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  run.frames = static_cast<int>(api.size());
  if (!error.empty()) Die(error);
  v1::GetMapRequest get;
  get.set_name("maps/scene");
  run.stats = service.GetMap(get)->stats();
  if (recognition) {
    v1::ListInstancesRequest list;
    list.set_map("maps/scene");
    list.set_page_size(1000);
    absl::StatusOr<v1::ListInstancesResponse> r =
        server::InstanceQueries(&service).ListInstances(list);
    if (!r.ok()) Die(r.status().ToString());
    run.instances.assign(r->instances().begin(), r->instances().end());
  }
  return run;
}

struct Truth {
  int obj_id;
  Eigen::Isometry3d pose;  // world <- model
};

struct Score {
  int gt = 0, found = 0, tp = 0;
};

Score Evaluate(const std::vector<Truth>& truth, const std::vector<v1::Instance>& instances,
               std::map<int, std::pair<int, int>>* per_object) {
  Score s;
  s.gt = static_cast<int>(truth.size());
  s.found = static_cast<int>(instances.size());
  std::vector<bool> used(instances.size(), false);
  for (const Truth& t : truth) {
    (*per_object)[t.obj_id].second++;
    int best = -1;
    double best_err = 1e9;
    for (size_t i = 0; i < instances.size(); ++i) {
      const v1::Instance& in = instances[i];
      if (used[i] || in.obj_id() != t.obj_id) continue;
      const Eigen::Vector3d p(in.pose().translation().x(), in.pose().translation().y(),
                              in.pose().translation().z());
      const Eigen::Quaterniond q(in.pose().rotation().w(), in.pose().rotation().x(),
                                 in.pose().rotation().y(), in.pose().rotation().z());
      const double dt = (p - t.pose.translation()).norm();
      const double dr = q.angularDistance(Eigen::Quaterniond(t.pose.linear())) * 180 / M_PI;
      std::fprintf(stderr,
                   "    obj %d: instance %llu  dt %.1f mm  dr %.1f deg  score %.0f fit %.2f\n",
                   t.obj_id, (unsigned long long)in.id(), dt * 1000, dr, in.score(), in.fit());
      if (dt <= 0.03 && dr <= 10 && dt < best_err) {
        best = static_cast<int>(i);
        best_err = dt;
      }
    }
    if (best >= 0) {
      used[best] = true;
      ++s.tp;
      (*per_object)[t.obj_id].first++;
    }
  }
  for (size_t i = 0; i < instances.size(); ++i) {
    if (used[i]) continue;
    const v1::Instance& in = instances[i];
    const Eigen::Vector3d p(in.pose().translation().x(), in.pose().translation().y(),
                            in.pose().translation().z());
    double nearest = 1e9;
    int near_obj = 0;
    for (const Truth& t : truth) {
      const double d = (p - t.pose.translation()).norm();
      if (d < nearest) {
        nearest = d;
        near_obj = t.obj_id;
      }
    }
    std::fprintf(stderr,
                 "    FP obj %d instance %llu: score %.0f fit %.2f support %llu/%llu, nearest GT "
                 "obj %d at %.0f mm\n",
                 in.obj_id(), (unsigned long long)in.id(), in.score(), in.fit(),
                 (unsigned long long)in.hypotheses(), (unsigned long long)in.frames(), near_obj,
                 nearest * 1000);
  }
  return s;
}

}  // namespace
}  // namespace skimap::bench

int main(int argc, char** argv) {
  using namespace skimap;
  using namespace skimap::bench;
  absl::ParseCommandLine(argc, argv);
  const std::string root = absl::GetFlag(FLAGS_dataset);
  absl::StatusOr<dataset::BopDataset> ds = dataset::LoadBopDataset(root);
  if (!ds.ok()) Die(ds.status().ToString());
  std::shared_ptr<const objects::ObjectDatabase> db = Database(root);
  std::vector<std::string> wanted;
  if (!absl::GetFlag(FLAGS_scenes).empty()) {
    wanted = absl::StrSplit(absl::GetFlag(FLAGS_scenes), ',');
  }
  std::printf(
      "| scene | frames | GT | instances | TP | precision | recall | whole pipeline frames/s "
      "(EVERY_FRAME) | mapping frames/s, recognition off | mapping frames/s, recognition on "
      "(NEWEST) | on / off | frames recognised (NEWEST) | control: off beside an idle-priority "
      "spinner, / off |\n"
      "|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  double off_total = 0, on_total = 0, control_total = 0, whole_seconds = 0;
  int whole_frames = 0;
  int mapped_frames = 0;
  Score total;
  std::map<int, std::pair<int, int>> per_object;
  for (const std::string& dir : ds->scenes["test"]) {
    const std::string name = std::filesystem::path(dir).filename();
    if (!wanted.empty() && std::find(wanted.begin(), wanted.end(), name) == wanted.end()) continue;
    absl::StatusOr<dataset::Sequence> seq = dataset::LoadBopScene(dir);
    if (!seq.ok()) Die(seq.status().ToString());
    std::vector<dataset::Frame> frames;
    for (size_t i = 0; i < seq->frames.size(); i += absl::GetFlag(FLAGS_every)) {
      frames.push_back(seq->frames[i]);
      if (absl::GetFlag(FLAGS_max_frames) > 0 &&
          static_cast<int>(frames.size()) >= absl::GetFlag(FLAGS_max_frames)) {
        break;
      }
    }
    std::vector<Truth> truth;
    for (const dataset::ObjectAnnotation& a : seq->frames.front().objects) {
      truth.push_back({a.obj_id, seq->frames.front().T_wc * a.T_m2c});
    }
    std::fprintf(stderr, "scene %s: %zu frames\n", name.c_str(), frames.size());
    const Run rec = Stream(db, frames, Mode::kEveryFrame);
    Samples off, on, control, recognised;  // milliseconds; frames recognised under NEWEST
    if (absl::GetFlag(FLAGS_mapping_only)) {
      for (int r = 0; r < std::max(1, absl::GetFlag(FLAGS_repeats)); ++r) {
        const Run mapping = Stream(db, frames, Mode::kOff);
        const Run newest = Stream(db, frames, Mode::kNewest);
        Run beside;
        {
          IdleSpinner spinner;
          beside = Stream(db, frames, Mode::kOff);
        }
        for (const Run* run : std::initializer_list<const Run*>{&newest, &beside, &rec}) {
          if (run->stats.voxels() != mapping.stats.voxels()) {
            Die(absl::StrCat("scene ", name, ": the runs built different maps (",
                             mapping.stats.voxels(), " and ", run->stats.voxels(), " voxels)"));
          }
        }
        off.Add(mapping.seconds * 1000);
        on.Add(newest.seconds * 1000);
        control.Add(beside.seconds * 1000);
        recognised.Add(static_cast<double>(newest.stats.recognized_frames()));
      }
      off_total += off.Median() / 1000;
      on_total += on.Median() / 1000;
      control_total += control.Median() / 1000;
      mapped_frames += static_cast<int>(frames.size());
    }
    whole_seconds += rec.seconds;
    whole_frames += rec.frames;
    const Score s = Evaluate(truth, rec.instances, &per_object);
    total.gt += s.gt;
    total.found += s.found;
    total.tp += s.tp;
    auto fps = [&](Samples& ms) { return ms.ms.empty() ? 0 : frames.size() * 1000 / ms.Median(); };
    const double off_fps = fps(off), on_fps = fps(on), control_fps = fps(control);
    std::printf(
        "| %s | %d | %d | %d | %d | %.2f | %.2f | %.1f | %.1f | %.1f | %.2f | %.0f | %.2f |\n",
        name.c_str(), rec.frames, s.gt, s.found, s.tp, s.found ? double(s.tp) / s.found : 0,
        s.gt ? double(s.tp) / s.gt : 0, rec.frames / rec.seconds, off_fps, on_fps,
        off_fps > 0 ? on_fps / off_fps : 0, recognised.Median(),
        off_fps > 0 ? control_fps / off_fps : 0);
    std::fflush(stdout);
  }
  auto rate = [&](double seconds) { return seconds > 0 ? mapped_frames / seconds : 0; };
  std::printf("| all | | %d | %d | %d | %.3f | %.3f | %.1f | %.1f | %.1f | %.2f | | %.2f |\n\n",
              total.gt, total.found, total.tp, total.found ? double(total.tp) / total.found : 0,
              total.gt ? double(total.tp) / total.gt : 0,
              whole_seconds > 0 ? whole_frames / whole_seconds : 0, rate(off_total), rate(on_total),
              on_total > 0 ? off_total / on_total : 0,
              control_total > 0 ? off_total / control_total : 0);
  std::printf("| obj_id | recall |\n|---|---|\n");
  for (const auto& [id, r] : per_object) std::printf("| %d | %d/%d |\n", id, r.first, r.second);
  return 0;
}
