// LiveMap's write path for frames (live_map.h): decoding ahead, the worker's groups of
// frames (the frames queued behind each other, one durable journal append for all), staging
// and applying them, and their acks.
#include <chrono>
#include <future>
#include <utility>

#include "absl/container/flat_hash_set.h"
#include "absl/strings/str_cat.h"
#include "server/core/maps/frame_decode.h"
#include "server/core/maps/live_map.h"

namespace skimap::server {
namespace {

using Clock = std::chrono::steady_clock;

// The queue task kind of a submitted frame (WorkQueue::TakeNextItem).
constexpr char kFrameWriteKind = 0;
// A worker group of frames: at most this many, and it stops growing past this many bytes.
// Eight 640x480 frames of raw colour are about 9 MB.
constexpr size_t kMaxGroupFrames = 16;
constexpr size_t kMaxGroupBytes = size_t{32} << 20;
// Journal payload buffers a map keeps between groups (LiveMap::journal_buffers_).
constexpr size_t kKeptJournalBytes = size_t{16} << 20;

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

// A frame SubmitFrame queued: the item of its worker task, which the worker may take with
// the frames before it (WorkQueue::TakeNextItem).
struct LiveMap::FrameWrite {
  std::shared_ptr<const v1::Frame> frame;
  std::shared_ptr<DecodeJob> job;  // may be null: decoded on the worker
  std::shared_ptr<FrameDone> done;
  // Out, set by IntegrateOnWorker.
  absl::StatusOr<v1::FrameAck> ack = absl::InternalError("frame not integrated");
  std::shared_ptr<const perception::RgbdFrame> decoded;  // for recognition, when it runs
};

void LiveMap::SubmitFrame(std::shared_ptr<const v1::Frame> frame, FrameDone done) {
  if (absl::Status s = Refused(); !s.ok()) return done(s);
  auto write = std::make_shared<FrameWrite>();
  write->frame = frame;
  write->done = std::make_shared<FrameDone>(std::move(done));
  if (options_.decoder != nullptr) write->job = StartDecode(frame);
  // The worker never changes write->job or write->done: both stay readable here.
  const bool queued =
      queue_.TrySubmit([this, write] { WriteFramesOnWorker(write); }, &kFrameWriteKind, write);
  if (!queued) {
    (*write->done)(absl::ResourceExhaustedError(
        absl::StrCat("map ", MapName(id_), ": write queue full (", options_.queue_capacity,
                     " pending, skimapd --queue_capacity); retry later")));
    return;
  }
  if (write->job != nullptr) StartDecodeParts(write->job);
}

void LiveMap::WriteFramesOnWorker(std::shared_ptr<FrameWrite> first) {
  // With a store, the frames queued right behind this one join it: one durable append for
  // all of them instead of one each (a commit and its fsync are most of a frame's wait).
  std::vector<std::shared_ptr<FrameWrite>> group{std::move(first)};
  if (options_.store != nullptr) {
    size_t bytes = group[0]->frame->ByteSizeLong();
    while (group.size() < kMaxGroupFrames && bytes < kMaxGroupBytes) {
      auto next = std::static_pointer_cast<FrameWrite>(queue_.TakeNextItem(&kFrameWriteKind));
      if (next == nullptr) break;
      bytes += next->frame->ByteSizeLong();
      group.push_back(std::move(next));
    }
  }
  std::vector<FrameWrite*> writes;
  for (const std::shared_ptr<FrameWrite>& w : group) writes.push_back(w.get());
  IntegrateOnWorker(writes, Source::kAppend, 0);
  for (const std::shared_ptr<FrameWrite>& w : group) {
    if (w->ack.ok() && w->decoded != nullptr) {
      // The every-frame policy acks after recognition: the ack then carries this frame.
      auto acked = std::make_shared<v1::FrameAck>(*w->ack);
      const bool taken = recognition_->Offer(
          w->frame->sequence(), *w->frame, std::move(w->decoded), [this, acked, done = w->done] {
            acked->set_recognized_frames(recognition_->recognized_frames());
            (*done)(*acked);
          });
      if (taken) continue;
      w->ack->set_recognized_frames(recognition_->recognized_frames());
    }
    (*w->done)(std::move(w->ack));
  }
}

absl::StatusOr<uint64_t> LiveMap::Journal(const std::vector<storage::JournalRecord>& records) {
  if (options_.store == nullptr) return 0;
  const Clock::time_point start = Clock::now();
  absl::StatusOr<uint64_t> position = options_.store->AppendJournal(id_, records);
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

absl::StatusOr<v1::FrameAck> LiveMap::IntegrateOnWorker(std::shared_ptr<const v1::Frame> frame,
                                                        Source source, uint64_t position) {
  FrameWrite write;
  write.frame = std::move(frame);
  FrameWrite* writes[] = {&write};
  IntegrateOnWorker(writes, source, position);
  return std::move(write.ack);
}

void LiveMap::IntegrateOnWorker(std::span<FrameWrite* const> writes, Source source,
                                uint64_t position) {
  const Clock::time_point start = Clock::now();
  // One per write: its decoded images (its job's, or a spare frame decoded here), which go
  // back to the spare buffers on every return unless recognition took them; a job's parts
  // are settled first (a decoder thread may still write them).
  struct Slot {
    LiveMap* map = nullptr;
    FrameWrite* write = nullptr;
    perception::RgbdFrame inline_frame;
    perception::RgbdFrame* decoded = nullptr;
    FrameIndex::Entry entry;
    perception::IntegrationStats stats;
    ~Slot() {
      if (write->job != nullptr) {
        for (DecodePart* part : {&write->job->depth, &write->job->color}) {
          if (!part->RunIfUnclaimed([] { return absl::OkStatus(); })) part->finished.wait();
        }
      }
      if (decoded != nullptr) map->ReturnSpareFrame(std::move(*decoded));
    }
  };
  std::vector<std::unique_ptr<Slot>> slots;
  std::vector<Slot*> valid;  // the frames that passed their checks, in order
  absl::flat_hash_set<uint64_t> sequences;
  const absl::Status refused = Refused();
  for (FrameWrite* w : writes) {
    Slot* slot = slots.emplace_back(std::make_unique<Slot>()).get();
    slot->map = this;
    slot->write = w;
    if (w->job != nullptr) {
      slot->decoded = &w->job->decoded;
    } else {
      slot->inline_frame = TakeSpareFrame();
      slot->decoded = &slot->inline_frame;
    }
    if (!refused.ok()) {
      w->ack = refused;
      continue;
    }
    const uint64_t sequence = w->frame->sequence();
    if (index_.Contains(sequence) || sequences.contains(sequence)) {
      w->ack = absl::AlreadyExistsError(
          absl::StrCat("sequence: frame ", sequence, " is already in ", MapName(id_)));
      continue;
    }
    absl::Status s =
        w->job != nullptr ? FinishDecode(*w->job) : DecodeFrameInto(*w->frame, slot->decoded);
    if (s.ok()) s = ValidatePoseInMap(slot->decoded->pose, options_.config, "pose");
    if (!s.ok()) {
      w->ack = s;
      continue;
    }
    sequences.insert(sequence);
    slot->entry.pose = slot->decoded->pose;
    valid.push_back(slot);
  }
  if (valid.empty()) return;

  // Each frame is staged and sealed on its own (applied as it would be alone).
  const auto stage = [&](Slot* v) {
    v->stats = StageFrame(*v->decoded, FrameStage::kAdd);
    for (const std::unique_ptr<FrameStage>& s : stages_) s->Seal();
  };
  uint64_t last_position = 0;
  if (options_.store != nullptr && source == Source::kAppend) {
    // Durable before it changes the map or is acknowledged: the records are appended on the
    // journal threads while this thread stages the frames, and applied only once durable.
    std::vector<storage::JournalRecord> records(valid.size());
    if (journal_buffers_.size() < valid.size()) journal_buffers_.resize(valid.size());
    for (size_t i = 0; i < valid.size(); ++i) {
      records[i].kind = storage::JournalRecord::kFrame;
      records[i].payload = std::move(journal_buffers_[i]);
      (void)valid[i]->write->frame->SerializeToString(&records[i].payload);
      valid[i]->entry.record_bytes = records[i].payload.size();
    }
    std::promise<absl::StatusOr<uint64_t>> appended;
    std::future<absl::StatusOr<uint64_t>> durable = appended.get_future();
    auto append = [&] { appended.set_value(Journal(records)); };
    if (options_.journal == nullptr || !options_.journal->Submit(append)) append();
    for (Slot* v : valid) stage(v);
    absl::StatusOr<uint64_t> position_or = durable.get();
    // Kept for the next group up to kKeptJournalBytes in all.
    size_t kept = 0;
    for (size_t i = 0; i < records.size(); ++i) {
      kept += records[i].payload.capacity();
      journal_buffers_[i] = kept <= kKeptJournalBytes ? std::move(records[i].payload) : "";
    }
    if (!position_or.ok()) {
      for (const std::unique_ptr<FrameStage>& s : stages_) s->Clear();
      for (Slot* v : valid) v->write->ack = position_or.status();
      return;
    }
    // One append numbers its records consecutively.
    last_position = *position_or;
    for (size_t i = 0; i < valid.size(); ++i) {
      valid[i]->entry.position = last_position - (valid.size() - 1 - i);
    }
  } else if (options_.store != nullptr) {  // replay: the record's own position
    last_position = position;
    for (Slot* v : valid) {
      v->entry.position = position;
      v->entry.record_bytes = v->write->frame->ByteSizeLong();
      stage(v);
    }
  } else {
    for (Slot* v : valid) {
      v->entry.position = ++arrivals_;
      v->entry.record_bytes = v->write->frame->ByteSizeLong();
      v->entry.frame = v->write->frame;
      stage(v);
    }
  }
  // The grid's views (grid_views.h), made outside the lock, kept in order.
  std::vector<GridViews::View> views;
  views.reserve(valid.size());
  for (Slot* v : valid)
    views.push_back(GridViews::MakeView(v->write->frame->sequence(), *v->decoded));
  std::vector<WriteStats> written;
  ApplyStages(
      valid.size(), last_position,
      [&](MapState& state) {
        for (GridViews::View& view : views) state.grid_views.Offer(std::move(view));
      },
      &written);
  written.resize(valid.size());
  for (Slot* v : valid) index_.Add(v->write->frame->sequence(), std::move(v->entry));
  if (options_.store == nullptr) index_.LimitKeptFrames(options_.max_kept_frame_bytes);
  kept_frame_bytes_.store(index_.kept_frame_bytes(), std::memory_order_relaxed);
  journal_bytes_.store(index_.journal_bytes(), std::memory_order_relaxed);
  NotifyChangeWatchers();
  for (size_t i = 0; i < valid.size(); ++i) {
    Slot* v = valid[i];
    v->write->ack = MakeAck(v->write->frame->sequence(), v->stats, written[i]);
    SetDuration(Clock::now() - start, v->write->ack->mutable_integration_time());
    if (options_.metrics != nullptr && source == Source::kAppend) {
      options_.metrics->IntegrationTook(absl::FromChrono(Clock::now() - start));
    }
    if (source == Source::kAppend && recognition_->running()) {
      v->write->decoded = std::make_shared<const perception::RgbdFrame>(std::move(*v->decoded));
      v->decoded = nullptr;
    }
  }
}

v1::FrameAck LiveMap::MakeAck(uint64_t sequence, const perception::IntegrationStats& stats,
                              const WriteStats& written) const {
  v1::FrameAck ack;
  ack.set_sequence(sequence);
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
  return ack;
}

perception::IntegrationStats LiveMap::StageFrame(const perception::RgbdFrame& frame,
                                                 FrameStage::Sign sign) {
  // stages_[0] is the frame's batch (on the pool); the stages after it (free space) are
  // offered to a decoder thread, to run beside it: their serial parts then use a core the
  // batch leaves idle. Whatever no decoder thread has started when the first is done, this
  // thread runs (a claim-once part, as a frame's decode parts). The stages own separate
  // batches; only the frame is shared (const).
  auto stage_rest = [this, &frame, sign] {
    for (size_t i = 1; i < stages_.size(); ++i) stages_[i]->Stage(frame, sign);
    return absl::OkStatus();
  };
  if (stages_.size() == 1 || options_.decoder == nullptr) {
    const perception::IntegrationStats first = stages_[0]->Stage(frame, sign);
    (void)stage_rest();
    return first;
  }
  auto rest = std::make_shared<DecodePart>();
  // The task touches the map and the frame only if it claims the part, and then this
  // thread waits for it below.
  (void)options_.decoder->TrySubmit([rest, stage_rest] { rest->RunIfUnclaimed(stage_rest); });
  const perception::IntegrationStats first = stages_[0]->Stage(frame, sign);
  if (!rest->RunIfUnclaimed(stage_rest)) rest->finished.wait();
  return first;
}

WriteStats LiveMap::ApplyStages(uint64_t frames_added, uint64_t position,
                                const std::function<void(MapState&)>& also,
                                std::vector<WriteStats>* per_sealed) {
  WriteStats total;
  WriterLock lock(&snapshot_mu_);
  for (const std::unique_ptr<FrameStage>& stage : stages_) {
    total += stage->Apply(&state_, per_sealed);
  }
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

}  // namespace skimap::server
