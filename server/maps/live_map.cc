#include "server/maps/live_map.h"

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
#include "server/logging/log.h"
#include "server/maps/chunk_codec.h"
#include "server/maps/frame_decode.h"
#include "server/maps/map_meta.h"

namespace skimap::server {
namespace {

using Clock = std::chrono::steady_clock;

void SetDuration(Clock::duration d, google::protobuf::Duration* out) {
  const auto ns = std::chrono::duration_cast<std::chrono::nanoseconds>(d).count();
  out->set_seconds(ns / 1000000000);
  out->set_nanos(static_cast<int32_t>(ns % 1000000000));
}

}  // namespace

// What a snapshot writes, copied on the worker: the journal position it covers, an
// encoder per changed chunk (run off the worker), the chunks left empty, the frame-index
// chunks, and the retention cut to prune after it is durable.
struct LiveMap::Capture {
  uint64_t position = 0;
  std::vector<std::function<storage::Chunk()>> encoders;
  std::vector<storage::ChunkKey> removed;
  std::vector<storage::Chunk> index_chunks;
  std::vector<std::pair<std::string, ChunkCoord>> coords;  // every captured volume chunk
  std::vector<int64_t> buckets;                            // every captured index chunk
  bool meta = false;                                       // the meta chunk was captured
  uint64_t prune_upto = 0;
  bool empty() const { return encoders.empty() && removed.empty() && index_chunks.empty(); }
};

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

namespace {

// Tells clang's thread-safety analysis that `mu` is held exclusively, in callbacks that run
// under it; checks nothing at run time.
void AssumeHeld(const RwLock& mu) ABSL_ASSERT_EXCLUSIVE_LOCK(mu) {}

constexpr char kFramesVolume[] = "frames";  // chunk volume name of the frame index
constexpr size_t kReplayBatch = 64;         // journal records read per store call

int64_t NowUnixMs() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

// Chunk coordinates read back from a store fit the key range (they were written by
// ChunkOf); anything else is corruption.
bool ValidChunkCoord(const storage::ChunkKey& k) {
  constexpr int64_t kMin = std::numeric_limits<int32_t>::min() >> kChunkShift;
  constexpr int64_t kMax = std::numeric_limits<int32_t>::max() >> kChunkShift;
  return k.x >= kMin && k.x <= kMax && k.y >= kMin && k.y <= kMax && k.z >= kMin && k.z <= kMax;
}

}  // namespace

LiveMap::LiveMap(std::string id, const Options& options)
    : id_(std::move(id)),
      incarnation_(uint64_t{std::random_device()()} << 32 | std::random_device()()),
      options_(options),
      state_(options.config, options.pool),
      stages_(MakeFrameStages(options.config, Grid(options.config.resolution), options.pool)),
      queue_({.capacity = options.queue_capacity, .nice = options.worker_nice}) {
  StartRecognition();
}

LiveMap::~LiveMap() {
  // Queued writes run first (they may hand frames to recognition), then recognition stops
  // (its last job may still use the worker), then the worker goes.
  Drain();
  recognition_.reset();
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
      const bool taken = OfferRecognition(
          frame->sequence(), *frame, std::move(decoded), [this, acked, shared_done] {
            acked->set_recognized_frames(recognized_frames_.load(std::memory_order_acquire));
            (*shared_done)(*acked);
          });
      if (taken) return;
      ack->set_recognized_frames(recognized_frames_.load(std::memory_order_acquire));
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

void LiveMap::SubmitPoseUpdates(std::shared_ptr<const v1::UpdatePosesRequest> request,
                                PosesDone done) {
  if (absl::Status s = Refused(); !s.ok()) return done(s);
  auto shared_done = std::make_shared<PosesDone>(std::move(done));
  const bool queued = queue_.TrySubmit([this, request, shared_done] {
    (*shared_done)(UpdatePosesOnWorker(*request, Source::kAppend, 0));
  });
  if (!queued) {
    (*shared_done)(absl::ResourceExhaustedError(
        absl::StrCat("map ", MapName(id_), ": write queue full; retry later")));
  }
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

absl::Status LiveMap::Load() {
  absl::Status loaded = queue_.Run([this] { return LoadSnapshotOnWorker(); });
  if (!loaded.ok()) return loaded;
  // The journal after the snapshot, in batches: replay reads the store again (pose
  // updates read their frames back), which ReadJournal's callback must not.
  uint64_t after = snapshot_position_.load(std::memory_order_acquire);
  for (;;) {
    std::vector<storage::JournalRecord> batch;
    absl::Status read =
        options_.store->ReadJournal(id_, after, kReplayBatch, [&](const storage::JournalRecord& r) {
          batch.push_back(r);
          return absl::OkStatus();
        });
    if (!read.ok()) return read;
    if (batch.empty()) return absl::OkStatus();
    for (const storage::JournalRecord& r : batch) {
      absl::Status s = queue_.Run([&] { return ReplayOnWorker(r); });
      if (absl::IsDataLoss(s)) return s;
      if (!s.ok()) {
        LogWarning(absl::StrCat("map ", MapName(id_), ": journal record ", r.position,
                                " skipped: ", s.ToString()));
      }
      after = r.position;
    }
  }
}

absl::Status LiveMap::LoadSnapshotOnWorker() {
  storage::MapStore& store = *options_.store;
  absl::StatusOr<storage::StoredMap> stored = store.GetMap(id_);
  if (!stored.ok()) return stored.status();
  auto chunk_error = [&](const storage::ChunkKey& k, const absl::Status& s) {
    return absl::Status(s.code(), absl::StrCat("snapshot of ", MapName(id_), ": chunk ", k.volume,
                                               " (", k.x, ",", k.y, ",", k.z, "): ", s.message()));
  };
  absl::StatusOr<uint64_t> covered;
  {
    WriterLock lock(&snapshot_mu_);
    covered = store.ReadSnapshot(id_, [&](const storage::Chunk& c) -> absl::Status {
      AssumeHeld(snapshot_mu_);  // ReadSnapshot calls back here, under the lock above
      if (c.key.volume == kFramesVolume) {
        absl::Status s = index_.DecodeBucket(c.key.x, c.bytes);
        return s.ok() ? s : chunk_error(c.key, s);
      }
      if (c.key.volume == kMetaVolume) {
        absl::StatusOr<MapMeta> meta = DecodeMapMeta(c.bytes);
        if (!meta.ok()) return chunk_error(c.key, meta.status());
        state_.recognition.next_instance_id = meta->next_instance_id;
        state_.recognition.log.Restart(meta->last_event_sequence);
        state_.recognition.fingerprint = meta->fingerprint;
        return absl::OkStatus();
      }
      if (!ValidChunkCoord(c.key)) {
        return chunk_error(c.key, absl::DataLossError("coordinates outside the key range"));
      }
      const ChunkCoord coord{int32_t(c.key.x), int32_t(c.key.y), int32_t(c.key.z)};
      absl::Status s = absl::FailedPreconditionError("unknown volume (written by a newer server?)");
      state_.ForEachVolume([&](const char* name, auto& volume, DirtyChunks&) {
        if (c.key.volume != name) return;
        using V = typename std::remove_reference_t<decltype(volume)>::VoxelType;
        VoxelBatch<V> batch;
        s = DecodeVoxelChunk<V>(coord, c.bytes, &batch);
        if (!s.ok()) return;
        batch.Finalize();  // sorted and unique already; marks the batch ready
        volume.Integrate(batch);
      });
      return s.ok() ? s : chunk_error(c.key, s);
    });
    if (!covered.ok()) return covered.status();
    state_.frames = index_.size();
    state_.journal_position = *covered;
    state_.ForEachVolume([](const char*, auto&, DirtyChunks& dirty) { dirty.clear(); });
  }
  (void)index_.TakeDirty();
  AfterLoadRecognition();
  // Records before the first one left in the journal were pruned.
  uint64_t first = 0;
  absl::Status read = store.ReadJournal(id_, 0, 1, [&](const storage::JournalRecord& r) {
    first = r.position;
    return absl::OkStatus();
  });
  if (!read.ok()) return read;
  const uint64_t pruned = first > 0 ? first - 1 : stored->last_position;
  index_.MarkPruned(pruned);
  pruned_position_.store(pruned, std::memory_order_release);
  journal_bytes_.store(index_.journal_bytes(), std::memory_order_release);
  journal_position_.store(std::max(*covered, pruned), std::memory_order_release);
  snapshot_position_.store(*covered, std::memory_order_release);
  snapshot_unix_ms_.store(stored->snapshot_unix_ms, std::memory_order_release);
  return absl::OkStatus();
}

absl::Status LiveMap::ReplayOnWorker(const storage::JournalRecord& record) {
  journal_position_.store(record.position, std::memory_order_release);
  if (record.kind == storage::JournalRecord::kFrame) {
    auto frame = std::make_shared<v1::Frame>();
    if (!frame->ParseFromString(record.payload)) {
      return absl::DataLossError(
          absl::StrCat("journal: ", MapName(id_), ": record ", record.position, " is not a Frame"));
    }
    return IntegrateOnWorker(frame, Source::kReplay, record.position).status();
  }
  v1::UpdatePosesRequest request;
  if (!request.ParseFromString(record.payload)) {
    return absl::DataLossError(absl::StrCat("journal: ", MapName(id_), ": record ", record.position,
                                            " is not an UpdatePosesRequest"));
  }
  return UpdatePosesOnWorker(request, Source::kReplay, record.position).status();
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
  ack.set_points_outside_map(stats.no_key);
  if (stats.points == 0 && stats.no_key > 0) {
    ack.set_message(absl::StrCat("integrated nothing: all ", stats.no_key,
                                 " points fall outside the map's key range"));
  } else if (stats.points == 0) {
    const perception::IntegrationOptions& o = options_.config.integration;
    ack.set_message(absl::StrCat("integrated nothing: no depth pixel in [", o.min_depth, ", ",
                                 o.max_depth, "] m (", stats.out_of_range,
                                 " valid pixels outside it)"));
  }
  SetDuration(Clock::now() - start, ack.mutable_integration_time());
  if (options_.metrics != nullptr && source == Source::kAppend) {
    options_.metrics->IntegrationTook(absl::FromChrono(Clock::now() - start));
  }
  if (decoded_out != nullptr && recognition_ != nullptr) {
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

absl::StatusOr<std::shared_ptr<const v1::Frame>> LiveMap::FrameOf(const FrameIndex::Entry& entry,
                                                                  uint64_t sequence,
                                                                  const std::string& field) {
  if (options_.store == nullptr) {
    if (entry.frame != nullptr) return entry.frame;
    return absl::FailedPreconditionError(absl::StrCat(
        field, ".sequence: frame ", sequence, " is no longer kept in memory (the newest ",
        options_.max_kept_frame_bytes, " bytes of frames are; this server has no data dir)"));
  }
  const auto pruned = [&] {
    return absl::FailedPreconditionError(
        absl::StrCat(field, ".sequence: frame ", sequence,
                     " is no longer in the journal: pruned by the ", RetentionPolicy(),
                     ", or left out of an export made without its journal (skimap export "
                     "--with-journal keeps it)"));
  };
  if (index_.Pruned(entry)) return pruned();
  absl::StatusOr<storage::JournalRecord> record =
      options_.store->ReadJournalRecord(id_, entry.position);
  if (absl::IsNotFound(record.status())) return pruned();
  if (!record.ok()) {
    return absl::Status(record.status().code(),
                        absl::StrCat("journal: ", MapName(id_), ": ", record.status().message()));
  }
  auto frame = std::make_shared<v1::Frame>();
  if (record->kind != storage::JournalRecord::kFrame || !frame->ParseFromString(record->payload)) {
    return absl::DataLossError(absl::StrCat("journal: ", MapName(id_), ": record ", entry.position,
                                            " is not frame ", sequence));
  }
  return frame;
}

absl::StatusOr<v1::UpdatePosesResponse> LiveMap::UpdatePosesOnWorker(
    const v1::UpdatePosesRequest& request, Source source, uint64_t position) {
  if (absl::Status s = Refused(); !s.ok()) return s;
  const Clock::time_point start = Clock::now();
  index_.MarkPruned(pruned_position_.load(std::memory_order_acquire));
  // Validate everything and read every frame back first: all or nothing.
  std::vector<perception::CameraPose> poses;
  std::vector<std::shared_ptr<const v1::Frame>> frames;
  absl::flat_hash_set<uint64_t> seen;
  for (int i = 0; i < request.updates_size(); ++i) {
    const v1::PoseUpdate& u = request.updates(i);
    const std::string field = absl::StrCat("updates[", i, "]");
    if (!seen.insert(u.sequence()).second) {
      return absl::InvalidArgumentError(
          absl::StrCat(field, ".sequence: frame ", u.sequence(), " appears twice"));
    }
    const FrameIndex::Entry* entry = index_.Find(u.sequence());
    if (entry == nullptr) {
      return absl::NotFoundError(absl::StrCat(field, ".sequence: frame ", u.sequence(),
                                              " was never integrated into ", MapName(id_)));
    }
    absl::StatusOr<perception::CameraPose> pose = DecodePose(u.pose(), u.has_pose());
    if (!pose.ok()) {
      return absl::InvalidArgumentError(absl::StrCat(field, ".", pose.status().message()));
    }
    if (absl::Status s = ValidatePoseInMap(*pose, options_.config, absl::StrCat(field, ".pose"));
        !s.ok()) {
      return s;
    }
    absl::StatusOr<std::shared_ptr<const v1::Frame>> frame = FrameOf(*entry, u.sequence(), field);
    if (!frame.ok()) return frame.status();
    poses.push_back(*pose);
    frames.push_back(*std::move(frame));
  }
  if (source == Source::kAppend) {
    absl::StatusOr<uint64_t> appended =
        Journal(storage::JournalRecord::kPoseUpdate, request.SerializeAsString());
    if (!appended.ok()) return appended.status();
    position = *appended;
  }
  // Every frame leaves with its old pose and comes back with the new one: staged outside
  // the lock (merged per voxel in each stage) ...
  for (int i = 0; i < request.updates_size(); ++i) {
    absl::StatusOr<perception::RgbdFrame> frame = DecodeFrame(*frames[i]);
    if (!frame.ok()) {  // decoded fine before: cannot happen
      for (const std::unique_ptr<FrameStage>& stage : stages_) stage->Clear();
      return frame.status();
    }
    const FrameIndex::Entry& entry = *index_.Find(request.updates(i).sequence());
    frame->pose = entry.pose;
    StageFrame(*frame, FrameStage::kRemove);
    if (entry.recognized) {
      StageRecognitionMove(request.updates(i).sequence(), *frame, entry.pose, poses[i]);
    }
    frame->pose = poses[i];
    StageFrame(*frame, FrameStage::kAdd);
  }
  // ... and applied in one snapshot: a reader sees every correction or none. The weights
  // are integer counts, so merged de-integration is exact.
  v1::UpdatePosesResponse response;
  const WriteStats total =
      ApplyStages(0, position, [&](MapState& state) { ApplyRecognitionMoves(state, position); });
  NotifyWatchers();
  NotifyChangeWatchers();
  for (int i = 0; i < request.updates_size(); ++i) {
    index_.SetPose(request.updates(i).sequence(), poses[i]);
  }
  response.set_frames_updated(request.updates_size());
  response.set_voxels_touched(total.voxels_touched);
  SetDuration(Clock::now() - start, response.mutable_time());
  return response;
}

std::unique_ptr<LiveMap::Capture> LiveMap::CaptureOnWorker() {
  auto c = std::make_unique<Capture>();
  index_.MarkPruned(pruned_position_.load(std::memory_order_acquire));
  // The dirty sets are taken under the exclusive lock (a moment); the chunks are copied
  // under the shared one, so queries go on meanwhile. Nothing changes in between: this is
  // the worker, the map's only writer.
  std::map<std::string, DirtyChunks> taken;
  {
    WriterLock lock(&snapshot_mu_);
    c->position = state_.journal_position;
    state_.ForEachVolume([&](const char* name, auto&, DirtyChunks& dirty) {
      taken[name] = std::move(dirty);
      dirty.clear();
    });
    recognition_changes_.store(0, std::memory_order_release);
    if (state_.recognition.meta_dirty) {
      state_.recognition.meta_dirty = false;
      c->meta = true;
      c->index_chunks.push_back(
          {{kMetaVolume, 0, 0, 0},
           EncodeMapMeta({.next_instance_id = state_.recognition.next_instance_id,
                          .last_event_sequence = state_.recognition.log.last_sequence(),
                          .fingerprint = state_.recognition.fingerprint})});
    }
  }
  ReaderLock lock(&snapshot_mu_);
  state_.ForEachVolume([&](const char* name, const auto& volume, const DirtyChunks&) {
    using V = typename std::remove_cvref_t<decltype(volume)>::VoxelType;
    for (const ChunkCoord& coord : taken[name]) {
      c->coords.emplace_back(name, coord);
      std::vector<typename VoxelBatch<V>::Item> items;
      volume.ForEachInBox(ChunkBox(coord), [&](const VoxelKey& k, const V& v) {
        items.push_back({k, v});
      });
      storage::ChunkKey key{name, coord.x, coord.y, coord.z};
      if (items.empty()) {
        c->removed.push_back(std::move(key));
        continue;
      }
      c->encoders.push_back([key = std::move(key), coord, items = std::move(items)] {
        return storage::Chunk{key, EncodeVoxelChunk<V>(coord, items)};
      });
    }
  });
  c->buckets = index_.TakeDirty();
  for (int64_t b : c->buckets) {
    storage::Chunk chunk;
    chunk.key.volume = kFramesVolume;
    chunk.key.x = b;
    chunk.bytes = index_.EncodeBucket(b);
    c->index_chunks.push_back(std::move(chunk));
  }
  c->prune_upto = index_.RetentionCut(c->position, options_.journal_retain_bytes);
  return c;
}

absl::Status LiveMap::Snapshot() {
  if (options_.store == nullptr) return absl::OkStatus();
  std::lock_guard<std::mutex> one_at_a_time(snapshot_run_mu_);
  if (snapshot_holds_.load(std::memory_order_acquire) > 0) return absl::OkStatus();
  return SnapshotLocked();
}

absl::StatusOr<LiveMap::SnapshotHold> LiveMap::SnapshotAndHold() {
  if (options_.store == nullptr) {
    return absl::FailedPreconditionError(
        absl::StrCat("map ", MapName(id_), " is in memory only (no store)"));
  }
  std::lock_guard<std::mutex> one_at_a_time(snapshot_run_mu_);
  if (absl::Status s = SnapshotLocked(); !s.ok()) return s;
  snapshot_holds_.fetch_add(1, std::memory_order_acq_rel);
  return SnapshotHold(this);
}

absl::Status LiveMap::SnapshotLocked() {
  std::unique_ptr<Capture> c = queue_.Run([this] { return CaptureOnWorker(); });
  const uint64_t pruned = pruned_position_.load(std::memory_order_acquire);
  if (c->empty() && c->position == snapshot_position_.load(std::memory_order_acquire) &&
      c->prune_upto <= pruned) {
    return absl::OkStatus();
  }
  std::vector<storage::Chunk> chunks = std::move(c->index_chunks);
  chunks.reserve(chunks.size() + c->encoders.size());
  for (const auto& encode : c->encoders) chunks.push_back(encode());
  absl::Status written = options_.store->WriteSnapshot(id_, c->position, chunks, c->removed);
  if (!written.ok()) {
    // Pending again: the next snapshot writes these chunks (with their newer content).
    {
      WriterLock lock(&snapshot_mu_);
      for (const auto& entry : c->coords) {  // (volume, chunk); clang 14 cannot capture bindings
        state_.ForEachVolume([&](const char* n, auto&, DirtyChunks& dirty) {
          if (entry.first == n) dirty.insert(entry.second);
        });
      }
      if (c->meta) state_.recognition.meta_dirty = true;
    }
    recognition_changes_.fetch_add(1, std::memory_order_acq_rel);
    (void)queue_.Submit([this, buckets = std::move(c->buckets)] { index_.MarkDirty(buckets); });
    return absl::Status(written.code(), absl::StrCat("snapshot of ", MapName(id_),
                                                     " not written: ", written.message()));
  }
  snapshot_position_.store(c->position, std::memory_order_release);
  snapshot_unix_ms_.store(NowUnixMs(), std::memory_order_release);
  if (c->prune_upto > pruned) {
    absl::Status s = options_.store->PruneJournal(id_, c->prune_upto);
    if (!s.ok()) {
      return absl::Status(s.code(),
                          absl::StrCat("journal of ", MapName(id_), " not pruned: ", s.message()));
    }
    pruned_position_.store(c->prune_upto, std::memory_order_release);
    (void)queue_.Submit([this, cut = c->prune_upto] {
      index_.MarkPruned(cut);
      journal_bytes_.store(index_.journal_bytes(), std::memory_order_relaxed);
    });
  }
  return absl::OkStatus();
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
  stats.set_recognition_skipped(recognition_ != nullptr ? recognition_->skipped() : 0);
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

}  // namespace skimap::server
