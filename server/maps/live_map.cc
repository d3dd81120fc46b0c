#include "server/maps/live_map.h"

#include <chrono>
#include <future>
#include <random>
#include <utility>

#include "absl/strings/str_cat.h"
#include "perception/frame_integrator.h"
#include "server/maps/frame_decode.h"

namespace skimap::server {
namespace {

using Clock = std::chrono::steady_clock;

void SetDuration(Clock::duration d, google::protobuf::Duration* out) {
  const auto ns = std::chrono::duration_cast<std::chrono::nanoseconds>(d).count();
  out->set_seconds(ns / 1000000000);
  out->set_nanos(static_cast<int32_t>(ns % 1000000000));
}

}  // namespace

LiveMap::LiveMap(std::string id, const Options& options)
    : id_(std::move(id)),
      incarnation_(uint64_t{std::random_device()()} << 32 | std::random_device()()),
      options_(options),
      state_(options.config, options.pool),
      stages_(MakeFrameStages(options.config, Grid(options.config.resolution), options.pool)),
      queue_({.capacity = options.queue_capacity}) {}

LiveMap::~LiveMap() = default;

absl::Status LiveMap::MapGone() const {
  return absl::NotFoundError(absl::StrCat("map ", MapName(id_), " was deleted"));
}

void LiveMap::SubmitFrame(std::shared_ptr<const v1::Frame> frame, FrameDone done) {
  if (deleted_.load(std::memory_order_acquire)) return done(MapGone());
  auto shared_done = std::make_shared<FrameDone>(std::move(done));
  const bool queued = queue_.TrySubmit(
      [this, frame, shared_done] { (*shared_done)(IntegrateOnWorker(frame, Source::kAppend)); });
  if (!queued) {
    (*shared_done)(absl::ResourceExhaustedError(
        absl::StrCat("map ", MapName(id_), ": write queue full (", options_.queue_capacity,
                     " pending); retry later")));
  }
}

void LiveMap::SubmitPoseUpdates(std::shared_ptr<const v1::UpdatePosesRequest> request,
                                PosesDone done) {
  if (deleted_.load(std::memory_order_acquire)) return done(MapGone());
  auto shared_done = std::make_shared<PosesDone>(std::move(done));
  const bool queued = queue_.TrySubmit([this, request, shared_done] {
    (*shared_done)(UpdatePosesOnWorker(*request, Source::kAppend));
  });
  if (!queued) {
    (*shared_done)(absl::ResourceExhaustedError(
        absl::StrCat("map ", MapName(id_), ": write queue full; retry later")));
  }
}

absl::Status LiveMap::Journal(storage::JournalRecord::Kind kind,
                              const google::protobuf::Message& m) {
  if (options_.store == nullptr) return absl::OkStatus();
  absl::StatusOr<uint64_t> position =
      options_.store->AppendJournal(id_, {{kind, m.SerializeAsString()}});
  if (position.ok()) {
    journal_position_.store(*position, std::memory_order_release);
    return absl::OkStatus();
  }
  return absl::Status(position.status().code(),
                      absl::StrCat("journal: ", MapName(id_), ": ", position.status().message(),
                                   " (not applied, not acknowledged)"));
}

absl::Status LiveMap::Replay(const storage::JournalRecord& record) {
  journal_position_.store(record.position, std::memory_order_release);
  std::promise<absl::Status> done;
  std::function<void()> task;
  if (record.kind == storage::JournalRecord::kFrame) {
    auto frame = std::make_shared<v1::Frame>();
    if (!frame->ParseFromString(record.payload)) {
      return absl::DataLossError(
          absl::StrCat("journal: ", MapName(id_), ": record ", record.position, " is not a Frame"));
    }
    task = [&, frame] { done.set_value(IntegrateOnWorker(frame, Source::kReplay).status()); };
  } else {
    auto request = std::make_shared<v1::UpdatePosesRequest>();
    if (!request->ParseFromString(record.payload)) {
      return absl::DataLossError(absl::StrCat("journal: ", MapName(id_), ": record ",
                                              record.position, " is not an UpdatePosesRequest"));
    }
    task = [&, request] {
      done.set_value(UpdatePosesOnWorker(*request, Source::kReplay).status());
    };
  }
  // Replay runs before the map serves and waits for each record, so the queue is empty.
  if (!queue_.TrySubmit(task)) {
    return absl::InternalError(absl::StrCat("journal: ", MapName(id_), ": replay while serving"));
  }
  return done.get_future().get();
}

absl::StatusOr<v1::FrameAck> LiveMap::IntegrateOnWorker(std::shared_ptr<const v1::Frame> frame,
                                                        Source source) {
  if (deleted_.load(std::memory_order_acquire)) return MapGone();
  const Clock::time_point start = Clock::now();
  if (sequences_.contains(frame->sequence())) {
    return absl::AlreadyExistsError(
        absl::StrCat("sequence: frame ", frame->sequence(), " is already in ", MapName(id_)));
  }
  absl::StatusOr<perception::RgbdFrame> decoded = DecodeFrame(*frame);
  if (!decoded.ok()) return decoded.status();
  if (absl::Status s = ValidatePoseInMap(decoded->pose, options_.config, "pose"); !s.ok()) {
    return s;
  }
  // Durable before it changes the map or is acknowledged.
  if (source == Source::kAppend) {
    if (absl::Status s = Journal(storage::JournalRecord::kFrame, *frame); !s.ok()) return s;
  }
  const perception::IntegrationStats stats = StageFrame(*decoded, FrameStage::kAdd);
  const WriteStats written = ApplyStages(1);
  sequences_.insert(frame->sequence());
  KeepFrame(frame->sequence(), {frame, decoded->pose});
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

WriteStats LiveMap::ApplyStages(uint64_t frames_added) {
  WriteStats total;
  WriterLock lock(&snapshot_mu_);
  for (const std::unique_ptr<FrameStage>& stage : stages_) total += stage->Apply(&state_);
  state_.frames += frames_added;
  return total;
}

void LiveMap::KeepFrame(uint64_t sequence, KeptFrame kept) {
  const size_t bytes = kept.frame->ByteSizeLong();
  kept_.emplace(sequence, std::move(kept));
  WriterLock lock(&snapshot_mu_);
  kept_bytes_ += bytes;
  while (kept_bytes_ > options_.max_kept_frame_bytes && !kept_.empty()) {
    kept_bytes_ -= kept_.begin()->second.frame->ByteSizeLong();
    kept_.erase(kept_.begin());
  }
}

absl::StatusOr<v1::UpdatePosesResponse> LiveMap::UpdatePosesOnWorker(
    const v1::UpdatePosesRequest& request, Source source) {
  if (deleted_.load(std::memory_order_acquire)) return MapGone();
  const Clock::time_point start = Clock::now();
  // Validate everything first: all or nothing.
  std::vector<perception::CameraPose> poses;
  std::unordered_set<uint64_t> seen;
  for (int i = 0; i < request.updates_size(); ++i) {
    const v1::PoseUpdate& u = request.updates(i);
    const std::string field = absl::StrCat("updates[", i, "]");
    if (!seen.insert(u.sequence()).second) {
      return absl::InvalidArgumentError(
          absl::StrCat(field, ".sequence: frame ", u.sequence(), " appears twice"));
    }
    if (!sequences_.contains(u.sequence())) {
      return absl::NotFoundError(absl::StrCat(field, ".sequence: frame ", u.sequence(),
                                              " was never integrated into ", MapName(id_)));
    }
    if (!kept_.contains(u.sequence())) {
      return absl::FailedPreconditionError(absl::StrCat(field, ".sequence: frame ", u.sequence(),
                                                        " is no longer kept (memory limit)"));
    }
    absl::StatusOr<perception::CameraPose> pose = DecodePose(u.pose(), u.has_pose());
    if (!pose.ok()) {
      return absl::InvalidArgumentError(absl::StrCat(field, ".", pose.status().message()));
    }
    if (absl::Status s = ValidatePoseInMap(*pose, options_.config, absl::StrCat(field, ".pose"));
        !s.ok()) {
      return s;
    }
    poses.push_back(*pose);
  }
  if (source == Source::kAppend) {
    if (absl::Status s = Journal(storage::JournalRecord::kPoseUpdate, request); !s.ok()) {
      return s;
    }
  }
  // Every frame leaves with its old pose and comes back with the new one: staged outside
  // the lock (merged per voxel in each stage) ...
  for (int i = 0; i < request.updates_size(); ++i) {
    const KeptFrame& kept = kept_.at(request.updates(i).sequence());
    absl::StatusOr<perception::RgbdFrame> frame = DecodeFrame(*kept.frame);
    if (!frame.ok()) {  // decoded fine before: cannot happen
      for (const std::unique_ptr<FrameStage>& stage : stages_) stage->Clear();
      return frame.status();
    }
    frame->pose = kept.pose;
    StageFrame(*frame, FrameStage::kRemove);
    frame->pose = poses[i];
    StageFrame(*frame, FrameStage::kAdd);
  }
  // ... and applied in one snapshot: a reader sees every correction or none. The weights
  // are integer counts, so merged de-integration is exact.
  v1::UpdatePosesResponse response;
  const WriteStats total = ApplyStages(0);
  for (int i = 0; i < request.updates_size(); ++i) {
    kept_.at(request.updates(i).sequence()).pose = poses[i];
  }
  response.set_frames_updated(request.updates_size());
  response.set_voxels_touched(total.voxels_touched);
  SetDuration(Clock::now() - start, response.mutable_time());
  return response;
}

v1::MapStats LiveMap::Stats() const {
  v1::MapStats stats;
  ReaderLock lock(&snapshot_mu_);
  stats.set_voxels(state_.rgb.size());
  stats.set_memory_bytes(state_.rgb.MemoryUsage() + state_.free.MemoryUsage());
  stats.set_frames(state_.frames);
  stats.set_kept_frame_bytes(kept_bytes_);
  stats.set_free_voxels(state_.free.size());
  stats.set_journal_position(journal_position_.load(std::memory_order_acquire));
  stats.set_persistent(options_.store != nullptr);
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
