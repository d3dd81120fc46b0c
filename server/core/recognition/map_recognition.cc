#include "server/core/recognition/map_recognition.h"

#include <algorithm>
#include <cstdio>
#include <random>
#include <set>

#include "absl/strings/str_cat.h"
#include "perception/recognition/active_sphere.h"
#include "server/core/logging/log.h"
#include "server/core/recognition/instance_reconciler.h"

namespace skimap::server {
namespace {

constexpr size_t kMaxHypothesesPerVoxel = 32;  // per object; the oldest frames' go first

Point3 AsPoint3(const Eigen::Vector3f& p) { return {p.x(), p.y(), p.z()}; }

int64_t TimestampMicros(const v1::Frame& frame) {
  if (!frame.has_timestamp()) return 0;
  return frame.timestamp().seconds() * 1000000 + frame.timestamp().nanos() / 1000;
}

// Every hypothesis of state's volume whose frame is in `frames`, with its key.
std::vector<std::pair<VoxelKey, Hypothesis>> HypothesesOfFrames(
    const HypothesesVolume& v, const std::map<uint64_t, Eigen::Isometry3d>& frames) {
  std::vector<std::pair<VoxelKey, Hypothesis>> out;
  v.ForEach([&](const VoxelKey& k, const HypothesesVoxel& voxel) {
    for (const Hypothesis& h : voxel.items()) {
      if (frames.contains(h.frame)) out.push_back({k, h});
    }
  });
  return out;
}

}  // namespace

MapRecognition::MapRecognition(const Options& options, const Map& map)
    : options_(options), map_(map), mu_(map.mu), state_(map.state) {
  Start();
}

void MapRecognition::Start() {
  const RecognitionConfig& rc = options_.config->recognition;
  if (!rc.enabled) return;
  std::shared_ptr<const objects::ObjectDatabase> db =
      options_.classifier ? options_.classifier() : nullptr;
  if (db == nullptr) {
    status_ = absl::FailedPreconditionError(
        absl::StrCat("map ", MapName(options_.map_id),
                     ": recognition is on but the server has no object classifier (train "
                     "objects and build it: skimap objects build)"));
    return;
  }
  absl::StatusOr<recognition::RecognitionModel> model =
      recognition::RecognitionModel::Create(std::move(db), rc.obj_ids);
  if (!model.ok()) {
    status_ = absl::FailedPreconditionError(absl::StrCat(
        "map ", MapName(options_.map_id), ": recognition is off: ", model.status().message()));
    return;
  }
  model_ = std::make_shared<const recognition::RecognitionModel>(*std::move(model));
  worker_observer_ = std::make_unique<recognition::LabelObserver>(*model_);
  view_keyframes_ = std::make_unique<ViewKeyframes>(
      ViewKeyframes::Options{.min_depth = options_.config->integration.min_depth});
  thread_observer_ = std::make_unique<recognition::LabelObserver>(*model_);
  queue_ = std::make_unique<RecognitionQueue>(
      RecognitionQueue::Options{.every_frame = rc.every_frame,
                                .nice = RecognitionNice(rc.every_frame, options_.worker_nice)},
      [this](RecognitionJob& job) { ObserveOnThread(job); },
      [this](RecognitionJob& job) { RecognizeOnThread(job); });
}

void MapRecognition::Flush() {
  if (queue_ != nullptr) queue_->Flush();
}

bool MapRecognition::Offer(uint64_t sequence, const v1::Frame& frame,
                           std::shared_ptr<const perception::RgbdFrame> decoded,
                           const std::function<void()>& done) {
  if (queue_ == nullptr || !decoded->color.has_value()) return false;
  const bool every_frame = options_.config->recognition.every_frame;
  queue_->Offer({.sequence = sequence,
                 .time_us = TimestampMicros(frame),
                 .frame = std::move(decoded),
                 .done = every_frame ? done : nullptr});
  return every_frame;
}

void MapRecognition::ObserveOnThread(RecognitionJob& job) {
  if (!map_.refused().ok()) return;
  const perception::IntegrationOptions& io = options_.config->integration;
  job.observed = thread_observer_->Observe(*job.frame, io.min_depth, io.max_depth);
  // The frame stays with the job: `run` checks instances against its depth (the view
  // conflict). At most one prepared job waits, so this holds one frame more.
}

void MapRecognition::RecognizeOnThread(RecognitionJob& job) {
  if (!map_.refused().ok()) return;
  const RecognitionConfig& rc = options_.config->recognition;
  const absl::StatusOr<recognition::LabelObservations>& observed = job.observed;
  if (!observed.ok()) {
    LogWarning(absl::StrCat(MapName(options_.map_id), ": recognition of frame ", job.sequence, ": ",
                            observed.status().ToString()));
    return;
  }
  const std::optional<perception::CameraPose> pose =
      map_.worker->Run([&] { return ApplyLabelsOnWorker(job.sequence, *observed); });
  if (!pose.has_value()) return;

  const recognition::Sphere sphere =
      recognition::ActiveSphere(*pose, *observed, rc.sphere_distance, rc.sphere_radius);

  // Matches per object (Eq. 7-8) from the labels in the sphere.
  std::vector<std::vector<recognition::LabelMatch>> matches(model_->num_objects());
  {
    ReaderLock lock(mu_);
    const Grid& g = state_->labels.grid();
    state_->labels.RadiusSearch(
        AsPoint3(sphere.centre), sphere.radius,
        [&](const VoxelKey& k, const MultiLabelVoxel& voxel) {
          // The voxel's heaviest label (paper §4.1: its maximal pair).
          const MultiLabelVoxel::Entry e = voxel.Heaviest();
          const Point3 c = g.Center(k);
          Eigen::Vector3f v;
          int o;
          if (!model_->ClassPoint(e.label, &v, &o)) return;
          matches[o].push_back({Eigen::Vector3f(c.x, c.y, c.z), v, static_cast<float>(e.count)});
        });
  }
  recognition::VotingOptions voting;
  voting.triples = rc.triples;
  voting.bin = static_cast<float>(rc.hough_bin);
  std::mt19937_64 rng(job.sequence * 0x9e3779b97f4a7c15ull + 1);  // deterministic per frame
  std::vector<Voted> voted;
  for (int o = 0; o < model_->num_objects(); ++o) {
    if (!model_->object(o).wanted || matches[o].size() < 3) continue;
    const std::vector<recognition::PoseEstimate> found =
        recognition::VotePoses(matches[o], model_->object(o), sphere, voting, rng);
    for (const recognition::PoseEstimate& e : found) {
      voted.push_back({o, e});
    }
  }
  map_.worker->Run([&] { ApplyHypothesesOnWorker(job, *pose, sphere, voted); });
}

std::optional<perception::CameraPose> MapRecognition::ApplyLabelsOnWorker(
    uint64_t sequence, const recognition::LabelObservations& observations) {
  if (!map_.refused().ok()) return std::nullopt;
  const FrameIndex::Entry* entry = map_.index->Find(sequence);
  if (entry == nullptr || entry->recognized) return std::nullopt;
  VoxelBatch<MultiLabelVoxel> batch;
  recognition::AddLabels(observations, entry->pose, labels_grid(), &batch);
  batch.Finalize();
  {
    WriterLock lock(mu_);
    MarkDirtyChunks(batch.items(), &state_->dirty_labels);
    if (!batch.empty()) state_->labels.Integrate(batch);
    ++state_->recognition.recognized_frames;
    if (state_->recognition.fingerprint != model_->fingerprint()) {
      state_->recognition.fingerprint = model_->fingerprint();
      state_->recognition.meta_dirty = true;
    }
  }
  map_.index->SetRecognized(sequence);
  recognized_frames_.fetch_add(1, std::memory_order_acq_rel);
  if (options_.metrics != nullptr) options_.metrics->FrameRecognized();
  Changed();
  return entry->pose;
}

void MapRecognition::ApplyHypothesesOnWorker(const RecognitionJob& job,
                                             const perception::CameraPose& pose,
                                             const recognition::Sphere& sphere,
                                             const std::vector<Voted>& voted) {
  if (!map_.refused().ok()) return;
  // Before the lock: a new vantage point's depth is copied (half resolution).
  view_keyframes_->Offer(job.sequence, job.frame->depth, job.frame->depth_scale, job.frame->camera,
                         perception::ToIsometry(pose));
  std::set<int> objects;
  int events = 0;
  {
    WriterLock lock(mu_);
    for (const Voted& v : voted) {
      const Eigen::Quaternionf q(v.estimate.pose.linear());
      const Eigen::Vector3f t = v.estimate.pose.translation();
      Hypothesis h{{t.x(), t.y(), t.z()},
                   {q.w(), q.x(), q.y(), q.z()},
                   static_cast<uint32_t>(model_->object(v.object_index).obj_id),
                   v.estimate.score,
                   job.sequence};
      VoxelKey key;
      if (!state_->hypotheses.grid().ToKey(t.x(), t.y(), t.z(), &key)) continue;
      // Bounded per voxel and object: the oldest frames' hypotheses make room.
      if (std::optional<HypothesesVoxel> there = state_->hypotheses.Find(key)) {
        std::vector<Hypothesis> mine;
        for (const Hypothesis& x : there->items()) {
          if (x.object_id == h.object_id) mine.push_back(x);
        }
        if (mine.size() >= kMaxHypothesesPerVoxel) {
          std::sort(mine.begin(), mine.end(),
                    [](const Hypothesis& a, const Hypothesis& b) { return a.frame < b.frame; });
          HypothesesVoxel old;
          for (size_t i = 0; i + kMaxHypothesesPerVoxel <= mine.size(); ++i) {
            old += HypothesesVoxel(mine[i]);
          }
          state_->hypotheses.DeintegrateKey(key, old);
        }
      }
      state_->hypotheses.IntegrateKey(key, HypothesesVoxel(h));
      state_->dirty_hypotheses.insert(ChunkOf(key));
      objects.insert(v.object_index);
    }
    const ReconcileParams params{
        .map_id = options_.map_id,
        .visible = ResolveVisibility(options_.config->recognition.visible, model_.get())};
    for (int o : objects) {
      events += ReconcileInstances(*model_, params,
                                   {.object_index = o,
                                    .region = sphere,
                                    .frame = job.sequence,
                                    .frame_time_us = job.time_us,
                                    .frame_supports = true,
                                    .views = view_keyframes_->views()},
                                   state_);
    }
  }
  Changed();
  if (events > 0) map_.instances_changed();
}

void MapRecognition::StageMove(uint64_t sequence, const perception::RgbdFrame& frame,
                               const perception::CameraPose& old_pose,
                               const perception::CameraPose& new_pose) {
  if (model_ == nullptr) return;  // labels of a database this server no longer has
  const perception::IntegrationOptions& io = options_.config->integration;
  absl::StatusOr<recognition::LabelObservations> observed =
      worker_observer_->Observe(frame, io.min_depth, io.max_depth);
  if (observed.ok()) {
    recognition::AddLabels(*observed, old_pose, labels_grid(), &labels_remove_);
    recognition::AddLabels(*observed, new_pose, labels_grid(), &labels_add_);
  }
  hypothesis_moves_[sequence] =
      perception::ToIsometry(new_pose) * perception::ToIsometry(old_pose).inverse();
  view_keyframes_->Move(sequence, perception::ToIsometry(new_pose));
}

void MapRecognition::ApplyMoves(MapState& state) {
  if (model_ == nullptr ||
      (labels_add_.empty() && labels_remove_.empty() && hypothesis_moves_.empty())) {
    labels_add_.Clear();
    labels_remove_.Clear();
    hypothesis_moves_.clear();
    return;
  }
  labels_remove_.Finalize();
  labels_add_.Finalize();
  MarkDirtyChunks(labels_remove_.items(), &state.dirty_labels);
  MarkDirtyChunks(labels_add_.items(), &state.dirty_labels);
  if (!labels_remove_.empty()) state.labels.Deintegrate(labels_remove_);
  if (!labels_add_.empty()) state.labels.Integrate(labels_add_);
  labels_remove_.Clear();
  labels_add_.Clear();

  // Hypotheses move with the frame that made them; then the instances of their objects are
  // reconciled around the old and new places together (an instance keeps its id).
  struct Region {
    Eigen::Vector3f lo = Eigen::Vector3f::Constant(1e30f), hi = Eigen::Vector3f::Constant(-1e30f);
  };
  std::map<uint32_t, Region> regions;  // by obj_id
  for (const auto& [key, h] : HypothesesOfFrames(state.hypotheses, hypothesis_moves_)) {
    const Eigen::Isometry3f delta = hypothesis_moves_.at(h.frame).cast<float>();
    Hypothesis moved = h;
    const Eigen::Vector3f t0(h.t[0], h.t[1], h.t[2]);
    const Eigen::Vector3f t1 = delta * t0;
    const Eigen::Quaternionf q1 =
        (Eigen::Quaternionf(delta.linear()) * Eigen::Quaternionf(h.q[0], h.q[1], h.q[2], h.q[3]))
            .normalized();
    moved.t = {t1.x(), t1.y(), t1.z()};
    moved.q = {q1.w(), q1.x(), q1.y(), q1.z()};
    state.hypotheses.DeintegrateKey(key, HypothesesVoxel(h));
    state.dirty_hypotheses.insert(ChunkOf(key));
    VoxelKey to;
    if (state.hypotheses.grid().ToKey(t1.x(), t1.y(), t1.z(), &to)) {
      state.hypotheses.IntegrateKey(to, HypothesesVoxel(moved));
      state.dirty_hypotheses.insert(ChunkOf(to));
    }
    Region& r = regions[h.object_id];
    r.lo = r.lo.cwiseMin(t0).cwiseMin(t1);
    r.hi = r.hi.cwiseMax(t0).cwiseMax(t1);
  }
  hypothesis_moves_.clear();
  const ReconcileParams params{
      .map_id = options_.map_id,
      .visible = ResolveVisibility(options_.config->recognition.visible, model_.get())};
  // Twice: the second pass sees every object's instances in their new places (one object's
  // instance can rule out another's where they would overlap).
  for (int pass = 0; pass < 2; ++pass) {
    for (const auto& [obj_id, r] : regions) {
      const int o = model_->FindObject(static_cast<int>(obj_id));
      if (o < 0) continue;
      ReconcileInstances(
          *model_, params,
          {.object_index = o,
           .region = {(r.lo + r.hi) / 2, 0.5f * (r.hi - r.lo).norm() + model_->object(o).radius},
           .frame = 0,
           .views = view_keyframes_->views()},
          &state);
    }
  }
  Changed();
}

void MapRecognition::AfterLoad() {
  WriterLock lock(mu_);
  // The lambdas below fill locals: clang's lock analysis checks a lambda as a function of
  // its own, where a captured alias of state_ would count as unguarded.
  RecognitionState& r = state_->recognition;
  r.recognized_frames = map_.index->recognized();
  absl::flat_hash_map<uint64_t, VoxelKey> instance_keys;
  state_->instances.ForEach([&](const VoxelKey& k, const InstancesVoxel& voxel) {
    for (const Instance& i : voxel.items()) instance_keys[i.id] = k;
  });
  r.instance_keys = std::move(instance_keys);
  recognized_frames_.store(r.recognized_frames, std::memory_order_release);
  if (model_ == nullptr || r.fingerprint == 0 || r.fingerprint == model_->fingerprint()) return;
  // Labels name classes of another object database: they mean nothing with this one. The
  // instances (object ids and poses) stay; labels and hypotheses start again.
  LogWarning(absl::StrCat(MapName(options_.map_id),
                          ": the object classifier changed since the map's labels were made; "
                          "its labels and hypotheses are cleared (instances are kept)"));
  DirtyChunks labels, hypotheses;
  state_->labels.ForEach(
      [&](const VoxelKey& k, const MultiLabelVoxel&) { labels.insert(ChunkOf(k)); });
  state_->hypotheses.ForEach(
      [&](const VoxelKey& k, const HypothesesVoxel&) { hypotheses.insert(ChunkOf(k)); });
  state_->dirty_labels.insert(labels.begin(), labels.end());
  state_->dirty_hypotheses.insert(hypotheses.begin(), hypotheses.end());
  state_->labels.Clear();
  state_->hypotheses.Clear();
  r.fingerprint = model_->fingerprint();
  r.meta_dirty = true;
  r.recognized_frames = 0;
  recognized_frames_.store(0, std::memory_order_release);
  map_.index->ClearRecognized();
  Changed();
}

}  // namespace skimap::server
