// LiveMap's pose updates: corrections of frames' camera poses (UpdatePoses). Each frame is
// read back from the journal (FrameOf), its old contribution subtracted and the frame
// integrated again at its new pose; recognition's volumes move with it. The write path is
// live_map.cc, persistence live_map_persistence.cc; the contract is live_map.h.
#include <chrono>
#include <memory>
#include <utility>

#include "absl/container/flat_hash_set.h"
#include "absl/strings/str_cat.h"
#include "server/core/maps/frame_decode.h"
#include "server/core/maps/live_map.h"

namespace skimap::server {

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

absl::StatusOr<v1::UpdatePosesResponse> LiveMap::UpdatePosesOnWorker(
    const v1::UpdatePosesRequest& request, Source source, uint64_t position) {
  if (absl::Status s = Refused(); !s.ok()) return s;
  const auto start = std::chrono::steady_clock::now();
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
        Journal({{storage::JournalRecord::kPoseUpdate, request.SerializeAsString()}});
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
      recognition_->StageMove(request.updates(i).sequence(), *frame, entry.pose, poses[i]);
    }
    frame->pose = poses[i];
    StageFrame(*frame, FrameStage::kAdd);
  }
  // ... and applied in one snapshot: a reader sees every correction or none. The weights
  // are integer counts, so merged de-integration is exact.
  v1::UpdatePosesResponse response;
  const WriteStats total = ApplyStages(0, position, [&](MapState& state) {
    recognition_->ApplyMoves(state);
    for (int i = 0; i < request.updates_size(); ++i) {
      state.grid_views.Move(request.updates(i).sequence(), perception::ToIsometry(poses[i]));
    }
  });
  NotifyWatchers();
  NotifyChangeWatchers();
  for (int i = 0; i < request.updates_size(); ++i) {
    index_.SetPose(request.updates(i).sequence(), poses[i]);
  }
  response.set_frames_updated(request.updates_size());
  response.set_voxels_touched(total.voxels_touched);
  SetDuration(std::chrono::steady_clock::now() - start, response.mutable_time());
  return response;
}

}  // namespace skimap::server
