// LiveMap: one map of the service: its MapState (every volume), the per-map pipeline of
// frame stages (frame_stages.h), the frames kept for pose updates, and the worker that
// runs writes in order.
//
//   LiveMap map("kitchen", {.config = config, .pool = &pool});
//   map.SubmitFrame(frame, [](absl::StatusOr<v1::FrameAck> ack) { ... });
//   absl::StatusOr<OccupancyGrid> grid =
//       map.Read([&](const MapState& s) { return ComputeOccupancyGrid(s.rgb, o); });
//
// Writes (frames, pose updates) run one at a time on the map's worker thread, fed by a
// bounded queue: a full queue answers ResourceExhausted at once instead of buffering.
// Decoding and every stage's Stage() run outside any lock; only the stages' Apply holds the
// snapshot lock exclusively, once per write (a pose update of any number of frames is one
// Apply). Readers (Read, Stats) hold it shared, so every read sees a consistent snapshot
// made of whole frames and whole pose updates.
//
// Thread safety: thread safe. Completion callbacks run on the worker thread (or on the
// submitting thread when the frame is refused up front) and must not block for long.
#ifndef SERVER_MAPS_LIVE_MAP_H_
#define SERVER_MAPS_LIVE_MAP_H_

#include <atomic>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <unordered_set>

#include "absl/base/thread_annotations.h"
#include "absl/status/statusor.h"
#include "perception/rgbd_frame.h"
#include "server/maps/frame_stages.h"
#include "server/maps/map_config.h"
#include "server/maps/map_state.h"
#include "server/work_queue.h"
#include "skimap/rw_lock.h"
#include "skimap/skimap.h"
#include "skimap/thread_pool.h"
#include "skimap/v1/frames.pb.h"
#include "skimap/v1/maps.pb.h"
#include "storage/map_store.h"

namespace skimap::server {

class LiveMap {
 public:
  struct Options {
    MapConfig config;
    ThreadPool* pool = nullptr;                     // threads for batch integration (not owned)
    size_t queue_capacity = 64;                     // queued writes before ResourceExhausted
    size_t max_kept_frame_bytes = size_t{1} << 30;  // oldest frames are dropped beyond
    // Journal: every accepted frame and pose update is appended (durably) here before it
    // is applied and acknowledged. Null: the map lives in memory only. Not owned.
    storage::MapStore* store = nullptr;
  };
  using FrameDone = std::function<void(absl::StatusOr<v1::FrameAck>)>;
  using PosesDone = std::function<void(absl::StatusOr<v1::UpdatePosesResponse>)>;

  LiveMap(std::string id, const Options& options);
  ~LiveMap();  // runs the queued writes (they answer NotFound after MarkDeleted)
  LiveMap(const LiveMap&) = delete;
  LiveMap& operator=(const LiveMap&) = delete;

  const std::string& id() const { return id_; }
  // Random at creation: tells this map from an earlier one with the same id (page tokens).
  uint64_t incarnation() const { return incarnation_; }
  const MapConfig& config() const { return options_.config; }

  // Queues `frame` (REQUIRES: frame.map() names this map). `done` runs exactly once with
  // the ack, or with: InvalidArgument (bad frame), AlreadyExists (sequence seen before),
  // ResourceExhausted (queue full), NotFound (map deleted meanwhile).
  void SubmitFrame(std::shared_ptr<const v1::Frame> frame, FrameDone done);
  // Queues pose corrections; `done` runs once. Validation is all-or-nothing:
  // InvalidArgument (bad pose, duplicate sequence), NotFound (unknown sequence),
  // FailedPrecondition (frame no longer kept); nothing is applied then.
  void SubmitPoseUpdates(std::shared_ptr<const v1::UpdatePosesRequest> request, PosesDone done);

  // Runs fn(const MapState&) on a consistent snapshot and returns its result. fn must not
  // call writers of this map.
  template <class Fn>
  auto Read(Fn&& fn) const {
    ReaderLock lock(&snapshot_mu_);
    return fn(state_);
  }
  // Counters from one snapshot.
  v1::MapStats Stats() const;

  // Re-applies one journal record (a frame or a pose update as it was accepted) without
  // journaling it again; blocks until the worker has applied it. For recovery at start,
  // before the map serves. DataLoss if the record does not parse.
  absl::Status Replay(const storage::JournalRecord& record);

  // Makes queued and future writes answer NotFound (the map left the registry).
  void MarkDeleted() { deleted_.store(true, std::memory_order_release); }

 private:
  struct KeptFrame {
    std::shared_ptr<const v1::Frame> frame;  // as received (encoded)
    perception::CameraPose pose;             // pose it is integrated with now
  };

  // kAppend: a new write, appended to the journal before it is applied; kReplay: a write
  // read back from the journal.
  enum class Source { kAppend, kReplay };
  // Worker thread only.
  absl::StatusOr<v1::FrameAck> IntegrateOnWorker(std::shared_ptr<const v1::Frame> frame,
                                                 Source source);
  absl::StatusOr<v1::UpdatePosesResponse> UpdatePosesOnWorker(const v1::UpdatePosesRequest& request,
                                                              Source source);
  // Appends one record to the store (OK without a store). The store's error otherwise,
  // prefixed "journal: ": the write must then not be applied or acknowledged.
  absl::Status Journal(storage::JournalRecord::Kind kind, const google::protobuf::Message& m);
  void KeepFrame(uint64_t sequence, KeptFrame kept);
  // Stages `frame` (with frame.pose) in every stage; the first stage's counts.
  perception::IntegrationStats StageFrame(const perception::RgbdFrame& frame,
                                          FrameStage::Sign sign);
  // Applies every stage's staged changes under the exclusive lock; `frames_added` is added
  // to the frame counter in the same snapshot.
  WriteStats ApplyStages(uint64_t frames_added);
  absl::Status MapGone() const;

  const std::string id_;
  const uint64_t incarnation_;
  const Options options_;
  std::atomic<bool> deleted_{false};
  std::atomic<uint64_t> journal_position_{0};  // last record durable in the store

  mutable RwLock snapshot_mu_;
  MapState state_ ABSL_GUARDED_BY(snapshot_mu_);
  size_t kept_bytes_ ABSL_GUARDED_BY(snapshot_mu_) = 0;

  // Touched only on the worker thread (tasks of queue_ run one at a time).
  std::map<uint64_t, KeptFrame> kept_;
  std::unordered_set<uint64_t> sequences_;
  std::vector<std::unique_ptr<FrameStage>> stages_;  // in order

  WorkQueue queue_;  // last: destroyed first, draining tasks while the rest is alive
};

}  // namespace skimap::server

#endif  // SERVER_MAPS_LIVE_MAP_H_
