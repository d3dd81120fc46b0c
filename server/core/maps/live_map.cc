#include "server/core/maps/live_map.h"

#include <chrono>
#include <cstdio>
#include <future>
#include <limits>
#include <map>
#include <random>
#include <type_traits>
#include <utility>

#include "absl/container/flat_hash_set.h"
#include "absl/strings/str_cat.h"
#include "perception/frame_integrator.h"
#include "server/core/logging/log.h"
#include "server/core/maps/frame_decode.h"
#include "server/core/transfer/chunk_codec.h"
#include "server/core/transfer/map_meta.h"

namespace skimap::server {
namespace {

using Clock = std::chrono::steady_clock;

}  // namespace

// One part (depth or colour) of a frame decoded ahead: whoever claims it first (a decoder
// thread or, when none has started it, the worker) decodes it; the worker waits for a part
// a decoder thread claimed.
struct DecodePart {
  std::atomic<bool> claimed{false};
  absl::Status status;  // written by the claimer before `done` is set
  std::promise<void> done;
  std::future<void> finished = done.get_future();
  // Runs decode() if this call claims the part; false if another thread had claimed it.
  template <class Fn>
  bool RunIfUnclaimed(Fn&& decode) {
    if (claimed.exchange(true, std::memory_order_acq_rel)) return false;
    status = decode();
    done.set_value();
    return true;
  }
};

struct LiveMap::DecodeJob {
  std::shared_ptr<const v1::Frame> frame;
  perception::RgbdFrame decoded;  // depth and colour written by their parts only
  absl::Status header;
  DecodePart depth, color;
};

LiveMap::LiveMap(std::string id, const Options& options)
    : id_(std::move(id)),
      incarnation_(uint64_t{std::random_device()()} << 32 | std::random_device()()),
      options_(options),
      state_(options.config, options.pool),
      stages_(MakeFrameStages(options.config, Grid(options.config.resolution), options.pool)),
      queue_({.capacity = options.queue_capacity, .nice = options.worker_nice}) {
  recognition_ = std::make_unique<MapRecognition>(
      MapRecognition::Options{.map_id = id_,
                              .config = &options_.config,
                              .worker_nice = options_.worker_nice,
                              .classifier = options_.classifier,
                              .metrics = options_.metrics},
      MapRecognition::Map{.mu = &snapshot_mu_,
                          .state = &state_,
                          .index = &index_,
                          .worker = &queue_,
                          .refused = [this] { return Refused(); },
                          .instances_changed = [this] { NotifyWatchers(); },
                          .changes = &recognition_changes_});
}

LiveMap::~LiveMap() {
  // Queued writes run first (they may hand frames to recognition), then recognition stops
  // (its last job may still use the worker), then the worker goes.
  Drain();
  recognition_->Stop();
}

absl::Status LiveMap::Refused() const {
  if (deleted_.load(std::memory_order_acquire)) {
    return absl::NotFoundError(absl::StrCat("map ", MapName(id_), " was deleted"));
  }
  if (evicted_.load(std::memory_order_acquire)) {
    return absl::UnavailableError(
        absl::StrCat("map ", MapName(id_), " was unloaded from memory meanwhile; retry"));
  }
  return absl::OkStatus();
}

std::string LiveMap::RetentionPolicy() const {
  return absl::StrCat(
      "retention policy: once snapshotted, the oldest frame records are pruned "
      "while the map's frame records exceed ",
      options_.journal_retain_bytes, " bytes (skimapd --journal_retain_mb)");
}

perception::RgbdFrame LiveMap::TakeSpareFrame() {
  MutexLock lock(&spare_mu_);
  if (spare_frames_.empty()) return {};
  perception::RgbdFrame frame = std::move(spare_frames_.back());
  spare_frames_.pop_back();
  return frame;
}

void LiveMap::ReturnSpareFrame(perception::RgbdFrame frame) {
  // Enough for the frames a stream keeps in flight; more are freed.
  constexpr size_t kMaxSpareFrames = 8;
  MutexLock lock(&spare_mu_);
  if (spare_frames_.size() < kMaxSpareFrames) spare_frames_.push_back(std::move(frame));
}

std::shared_ptr<LiveMap::DecodeJob> LiveMap::StartDecode(std::shared_ptr<const v1::Frame> frame) {
  auto job = std::make_shared<DecodeJob>();
  job->frame = std::move(frame);
  job->decoded = TakeSpareFrame();
  job->header = DecodeFrameHeader(*job->frame, &job->decoded);
  return job;
}

void LiveMap::StartDecodeParts(const std::shared_ptr<DecodeJob>& job) {
  if (options_.decoder == nullptr || !job->header.ok()) return;
  // A full decoder leaves the part to the worker (FinishDecode).
  (void)options_.decoder->TrySubmit([job] {
    job->depth.RunIfUnclaimed([&] { return DecodeFrameDepth(*job->frame, &job->decoded); });
  });
  (void)options_.decoder->TrySubmit([job] {
    job->color.RunIfUnclaimed([&] { return DecodeFrameColor(*job->frame, &job->decoded); });
  });
}

absl::Status LiveMap::FinishDecode(DecodeJob& job) {
  if (!job.header.ok()) return job.header;
  if (!job.depth.RunIfUnclaimed([&] { return DecodeFrameDepth(*job.frame, &job.decoded); })) {
    job.depth.finished.wait();
  }
  if (!job.depth.status.ok()) {
    // Colour may still be decoding into the job's frame: it must finish before the job
    // (and its buffers) can go.
    if (!job.color.RunIfUnclaimed([] { return absl::OkStatus(); })) job.color.finished.wait();
    return job.depth.status;
  }
  if (!job.color.RunIfUnclaimed([&] { return DecodeFrameColor(*job.frame, &job.decoded); })) {
    job.color.finished.wait();
  }
  return job.color.status;
}

void LiveMap::SubmitFrame(std::shared_ptr<const v1::Frame> frame, FrameDone done) {
  if (absl::Status s = Refused(); !s.ok()) return done(s);
  auto shared_done = std::make_shared<FrameDone>(std::move(done));
  std::shared_ptr<DecodeJob> job = options_.decoder != nullptr ? StartDecode(frame) : nullptr;
  const bool queued = queue_.TrySubmit([this, frame, shared_done, job] {
    std::shared_ptr<const perception::RgbdFrame> decoded;
    absl::StatusOr<v1::FrameAck> ack = IntegrateOnWorker(frame, Source::kAppend, 0, &decoded, job);
    if (ack.ok() && decoded != nullptr) {
      // The every-frame policy acks after recognition: the ack then carries this frame.
      auto acked = std::make_shared<v1::FrameAck>(*ack);
      const bool taken = recognition_->Offer(
          frame->sequence(), *frame, std::move(decoded), [this, acked, shared_done] {
            acked->set_recognized_frames(recognition_->recognized_frames());
            (*shared_done)(*acked);
          });
      if (taken) return;
      ack->set_recognized_frames(recognition_->recognized_frames());
    }
    (*shared_done)(std::move(ack));
  });
  if (!queued) {
    (*shared_done)(absl::ResourceExhaustedError(
        absl::StrCat("map ", MapName(id_), ": write queue full (", options_.queue_capacity,
                     " pending, skimapd --queue_capacity); retry later")));
    return;
  }
  if (job != nullptr) StartDecodeParts(job);
}

absl::StatusOr<uint64_t> LiveMap::Journal(storage::JournalRecord::Kind kind,
                                          const std::string& bytes) {
  if (options_.store == nullptr) return 0;
  const Clock::time_point start = Clock::now();
  absl::StatusOr<uint64_t> position = options_.store->AppendJournal(id_, {{kind, bytes}});
  if (options_.metrics != nullptr) {
    options_.metrics->JournalAppendTook(absl::FromChrono(Clock::now() - start));
  }
  if (position.ok()) {
    journal_position_.store(*position, std::memory_order_release);
    return *position;
  }
  return absl::Status(position.status().code(),
                      absl::StrCat("journal: ", MapName(id_), ": ", position.status().message(),
                                   " (not applied, not acknowledged)"));
}

absl::StatusOr<v1::FrameAck> LiveMap::IntegrateOnWorker(
    std::shared_ptr<const v1::Frame> frame, Source source, uint64_t position,
    std::shared_ptr<const perception::RgbdFrame>* decoded_out,
    const std::shared_ptr<DecodeJob>& job) {
  // The decoded images go back to the spare buffers on every return, unless recognition
  // took them; a job's parts are settled first (a decoder thread may still write them).
  perception::RgbdFrame inline_frame = job == nullptr ? TakeSpareFrame() : perception::RgbdFrame();
  perception::RgbdFrame* decoded = job == nullptr ? &inline_frame : &job->decoded;
  struct Recycle {
    LiveMap* map;
    DecodeJob* job;
    perception::RgbdFrame* frame;
    ~Recycle() {
      if (job != nullptr) {
        for (DecodePart* part : {&job->depth, &job->color}) {
          if (!part->RunIfUnclaimed([] { return absl::OkStatus(); })) part->finished.wait();
        }
      }
      if (frame != nullptr) map->ReturnSpareFrame(std::move(*frame));
    }
  } recycle{this, job.get(), decoded};
  if (absl::Status s = Refused(); !s.ok()) return s;
  const Clock::time_point start = Clock::now();
  if (index_.Contains(frame->sequence())) {
    return absl::AlreadyExistsError(
        absl::StrCat("sequence: frame ", frame->sequence(), " is already in ", MapName(id_)));
  }
  if (absl::Status s = job != nullptr ? FinishDecode(*job) : DecodeFrameInto(*frame, decoded);
      !s.ok()) {
    return s;
  }
  if (absl::Status s = ValidatePoseInMap(decoded->pose, options_.config, "pose"); !s.ok()) {
    return s;
  }
  FrameIndex::Entry entry{.pose = decoded->pose};
  perception::IntegrationStats stats;
  if (options_.store != nullptr) {
    const std::string record = frame->SerializeAsString();
    entry.record_bytes = record.size();
    // Durable before it changes the map or is acknowledged: the record is appended on the
    // journal threads while this thread stages the frame, and applied only once durable.
    if (source == Source::kAppend) {
      std::promise<absl::StatusOr<uint64_t>> appended;
      std::future<absl::StatusOr<uint64_t>> durable = appended.get_future();
      auto append = [&] { appended.set_value(Journal(storage::JournalRecord::kFrame, record)); };
      if (options_.journal == nullptr || !options_.journal->Submit(append)) append();
      stats = StageFrame(*decoded, FrameStage::kAdd);
      absl::StatusOr<uint64_t> position_or = durable.get();
      if (!position_or.ok()) {
        for (const std::unique_ptr<FrameStage>& stage : stages_) stage->Clear();
        return position_or.status();
      }
      position = *position_or;
    } else {
      stats = StageFrame(*decoded, FrameStage::kAdd);
    }
    entry.position = position;
  } else {
    entry.position = ++arrivals_;
    entry.record_bytes = frame->ByteSizeLong();
    entry.frame = frame;
    stats = StageFrame(*decoded, FrameStage::kAdd);
  }
  const WriteStats written = ApplyStages(1, position);
  index_.Add(frame->sequence(), std::move(entry));
  if (options_.store == nullptr) index_.LimitKeptFrames(options_.max_kept_frame_bytes);
  kept_frame_bytes_.store(index_.kept_frame_bytes(), std::memory_order_relaxed);
  journal_bytes_.store(index_.journal_bytes(), std::memory_order_relaxed);
  NotifyChangeWatchers();
  v1::FrameAck ack;
  ack.set_sequence(frame->sequence());
  ack.set_voxels_touched(written.voxels_touched);
  ack.set_points(stats.points);
  ack.set_points_out_of_range(stats.out_of_range);
  ack.set_points_at_depth_edges(stats.depth_edges);
  ack.set_points_outside_map(stats.no_key);
  if (stats.points == 0 && stats.no_key > 0) {
    ack.set_message(absl::StrCat("integrated nothing: all ", stats.no_key,
                                 " points fall outside the map's key range"));
  } else if (stats.points == 0) {
    const perception::IntegrationOptions& o = options_.config.integration;
    ack.set_message(absl::StrCat(
        "integrated nothing: no depth pixel in [", o.min_depth, ", ", o.max_depth, "] m (",
        stats.out_of_range, " valid pixels outside it",
        stats.depth_edges > 0
            ? absl::StrCat(", ", stats.depth_edges, " dropped at depth edges (depth_edge_jump)")
            : "",
        ")"));
  }
  SetDuration(Clock::now() - start, ack.mutable_integration_time());
  if (options_.metrics != nullptr && source == Source::kAppend) {
    options_.metrics->IntegrationTook(absl::FromChrono(Clock::now() - start));
  }
  if (decoded_out != nullptr && recognition_->running()) {
    *decoded_out = std::make_shared<const perception::RgbdFrame>(std::move(*decoded));
    recycle.frame = nullptr;
  }
  return ack;
}

perception::IntegrationStats LiveMap::StageFrame(const perception::RgbdFrame& frame,
                                                 FrameStage::Sign sign) {
  perception::IntegrationStats first;
  for (size_t i = 0; i < stages_.size(); ++i) {
    const perception::IntegrationStats stats = stages_[i]->Stage(frame, sign);
    if (i == 0) first = stats;
  }
  return first;
}

WriteStats LiveMap::ApplyStages(uint64_t frames_added, uint64_t position,
                                const std::function<void(MapState&)>& also) {
  WriteStats total;
  WriterLock lock(&snapshot_mu_);
  for (const std::unique_ptr<FrameStage>& stage : stages_) total += stage->Apply(&state_);
  if (also) also(state_);
  state_.frames += frames_added;
  if (position > 0) state_.journal_position = position;
  return total;
}

void LiveMap::SetDuration(std::chrono::steady_clock::duration d, google::protobuf::Duration* out) {
  const auto ns = std::chrono::duration_cast<std::chrono::nanoseconds>(d).count();
  out->set_seconds(ns / 1000000000);
  out->set_nanos(static_cast<int32_t>(ns % 1000000000));
}

v1::MapStats LiveMap::Stats() const {
  v1::MapStats stats;
  ReaderLock lock(&snapshot_mu_);
  stats.set_voxels(state_.rgb.size());
  size_t memory = 0;
  state_.ForEachVolume(
      [&](const char*, const auto& volume, const DirtyChunks&) { memory += volume.MemoryUsage(); });
  stats.set_memory_bytes(memory);
  stats.set_recognized_frames(state_.recognition.recognized_frames);
  stats.set_recognition_skipped(recognition_->skipped());
  stats.set_label_voxels(state_.labels.size());
  stats.set_hypothesis_voxels(state_.hypotheses.size());
  stats.set_instances(state_.recognition.instance_keys.size());
  stats.set_instance_event_sequence(state_.recognition.log.last_sequence());
  stats.set_frames(state_.frames);
  stats.set_kept_frame_bytes(kept_frame_bytes_.load(std::memory_order_relaxed));
  stats.set_free_voxels(state_.free.size());
  stats.set_journal_position(journal_position_.load(std::memory_order_acquire));
  stats.set_persistent(options_.store != nullptr);
  stats.set_snapshot_position(snapshot_position_.load(std::memory_order_acquire));
  if (const int64_t ms = snapshot_unix_ms_.load(std::memory_order_acquire); ms > 0) {
    stats.mutable_snapshot_time()->set_seconds(ms / 1000);
    stats.mutable_snapshot_time()->set_nanos(static_cast<int32_t>(ms % 1000) * 1000000);
  }
  stats.set_pruned_position(pruned_position_.load(std::memory_order_acquire));
  stats.set_journal_bytes(journal_bytes_.load(std::memory_order_relaxed));
  stats.set_loaded(true);
  if (std::optional<KeyBox> box = state_.rgb.Bounds()) {
    const Grid& g = state_.rgb.grid();
    const double r = g.resolution();
    auto* b = stats.mutable_bounds();
    b->mutable_min()->set_x(g.origin().x + box->min.x * r);
    b->mutable_min()->set_y(g.origin().y + box->min.y * r);
    b->mutable_min()->set_z(g.origin().z + box->min.z * r);
    b->mutable_max()->set_x(g.origin().x + (box->max.x + 1) * r);
    b->mutable_max()->set_y(g.origin().y + (box->max.y + 1) * r);
    b->mutable_max()->set_z(g.origin().z + (box->max.z + 1) * r);
  }
  return stats;
}

uint64_t LiveMap::AddInstanceWatcher(std::function<void()> wake) {
  std::lock_guard<std::mutex> lock(watchers_mu_);
  const uint64_t id = next_watcher_++;
  watchers_[id] = std::move(wake);
  return id;
}

void LiveMap::RemoveInstanceWatcher(uint64_t id) {
  std::lock_guard<std::mutex> lock(watchers_mu_);
  watchers_.erase(id);
}

uint64_t LiveMap::AddChangeWatcher(std::function<void()> wake) {
  std::lock_guard<std::mutex> lock(watchers_mu_);
  const uint64_t id = next_watcher_++;
  change_watchers_[id] = std::move(wake);
  return id;
}

void LiveMap::RemoveChangeWatcher(uint64_t id) {
  std::lock_guard<std::mutex> lock(watchers_mu_);
  change_watchers_.erase(id);
}

void LiveMap::NotifyChangeWatchers() {
  std::lock_guard<std::mutex> lock(watchers_mu_);
  for (auto& [id, wake] : change_watchers_) wake();
}

void LiveMap::NotifyWatchers() {
  std::lock_guard<std::mutex> lock(watchers_mu_);
  for (auto& [id, wake] : watchers_) wake();
}

}  // namespace skimap::server
