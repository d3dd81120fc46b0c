// LiveMap: one map of the service: its MapState (every volume), the per-map pipeline of
// frame stages (frame_stages.h), its frame index (frame_index.h), the worker that runs
// writes in order, and its persistence: the journal (every write durable before it is
// applied and acknowledged), incremental snapshots, reload and retention.
//
//   LiveMap map("kitchen", {.config = config, .pool = &pool});
//   map.SubmitFrame(frame, [](absl::StatusOr<v1::FrameAck> ack) { ... });
//   absl::StatusOr<OccupancyGrid> grid =
//       map.Read([&](const MapState& s) { return ComputeOccupancyGrid(s.rgb, o); });
//
// Writes (frames, pose updates) run one at a time on the map's worker thread, fed by a
// bounded queue: a full queue answers ResourceExhausted at once instead of buffering.
// A submitted frame's images are decoded ahead, on Options::decoder, depth and colour at
// once, while the worker integrates the frames before it (the ingestion pipeline); what a
// frame's write does and answers is the same as decoding it on the worker. With a store,
// the frames queued behind the one the worker takes join it as a group: one durable journal
// append for all of them, each frame still checked, applied (as its own integration) and
// answered on its own (live_map_frames.cc).
// Decoding and every stage's Stage() run outside any lock; only the stages' Apply holds the
// snapshot lock exclusively, once per write (a pose update of any number of frames, or a
// group of frames, is one Apply). Readers (Read, Stats) hold it shared, so every read sees a
// consistent snapshot made of whole frames and whole pose updates.
//
// Recognition (maps with options.recognition.enabled; docs/recognition.md): the worker
// hands each integrated frame to the map's MapRecognition (map_recognition.h), whose
// threads detect and classify features, fuse labels, vote and reconcile instances; every
// write to the MapState stays on the worker.
//
// Thread safety: thread safe. Completion callbacks run on the worker thread (or on the
// submitting thread when the frame is refused up front, or on the recognition thread for
// acks of maps with the every-frame policy) and must not block for long.
#ifndef SERVER_CORE_MAPS_LIVE_MAP_H_
#define SERVER_CORE_MAPS_LIVE_MAP_H_

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/status/statusor.h"
#include "base/mutex.h"
#include "base/rw_lock.h"
#include "base/thread_pool.h"
#include "perception/objects/object_database.h"
#include "perception/rgbd_frame.h"
#include "server/core/common/work_queue.h"
#include "server/core/maps/frame_index.h"
#include "server/core/maps/frame_stages.h"
#include "server/core/maps/map_config.h"
#include "server/core/maps/map_state.h"
#include "server/core/metrics/metrics.h"
#include "server/core/recognition/map_recognition.h"
#include "skimap/skimap.h"
#include "skimap/v1/frames.pb.h"
#include "skimap/v1/maps.pb.h"
#include "storage/map_store.h"

namespace skimap::server {

class LiveMap {
 public:
  struct Options {
    MapConfig config;
    ThreadPool* pool = nullptr;  // threads for batch integration (not owned)
    // Threads that decode a frame's depth and colour (at once, into reused buffers) as soon
    // as it is submitted, so decoding the next frames overlaps integrating this one; the
    // worker decodes what they have not started. Null: the worker decodes. Not owned; must
    // outlive the map.
    WorkQueue* decoder = nullptr;
    size_t queue_capacity = 64;  // queued writes before ResourceExhausted
    int worker_nice = 0;         // the map worker's niceness (MapService::Options::ingest_nice)
    size_t max_kept_frame_bytes = size_t{1} << 30;  // without a store: frames kept in memory
    // Journal and snapshots: every accepted frame and pose update is appended (durably)
    // here before it is applied and acknowledged. Null: the map lives in memory only and
    // UpdatePoses works on the frames kept in memory. Not owned.
    storage::MapStore* store = nullptr;
    // Threads that append a frame's journal record while the worker stages the frame
    // (back-projection, batch, sort), so the disk write overlaps that work instead of
    // preceding it; the frame is applied and acknowledged only once its record is durable.
    // Null: the worker appends first. Not owned; must outlive the map.
    WorkQueue* journal = nullptr;
    // Retention policy: once a snapshot covers them, the oldest frame records are pruned
    // from the journal while the map's frame records weigh more than this.
    uint64_t journal_retain_bytes = uint64_t{1} << 30;
    // The object database maps with recognition use, asked once when the map is created
    // or loaded (the map keeps that one). Null, or returning null: no recognition.
    std::function<std::shared_ptr<const objects::ObjectDatabase>()> classifier;
    // Integration and journal latencies, recognised frames (not owned); null: none.
    Metrics* metrics = nullptr;
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
  // ResourceExhausted (queue full), NotFound (map deleted meanwhile), or the store's error
  // prefixed "journal:" (not journaled: neither applied nor acknowledged).
  void SubmitFrame(std::shared_ptr<const v1::Frame> frame, FrameDone done);
  // Queues pose corrections; `done` runs once. Validation is all-or-nothing:
  // InvalidArgument (bad pose, duplicate sequence), NotFound (unknown sequence),
  // FailedPrecondition (the frame's record was pruned by the retention policy, or, without
  // a store, the frame is no longer kept in memory); nothing is applied then.
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
  // Writes queued on the worker, not started yet.
  size_t queued_writes() const { return queue_.pending(); }

  // Loads the map from the store: the latest snapshot, then the journal records after it.
  // A record that no longer applies (refused by today's validation) is reported on stderr
  // and skipped. DataLoss (corrupt chunk or record), FailedPrecondition (written by a newer
  // server) or the store's error. REQUIRES: a store; called once, before the map serves.
  absl::Status Load();

  // Writes a snapshot covering every write applied so far: the chunks of every volume and
  // of the frame index changed since the last snapshot, then prunes the journal by the
  // retention policy. The changed chunks are copied on the map's worker (writes wait for
  // the copy only); they are encoded and written on the calling thread. OK without a
  // store or when nothing changed, and while a SnapshotHold lives (below). On error the
  // changes stay pending for the next one. Thread safe: snapshots of one map run one at a
  // time.
  absl::Status Snapshot();
  // Export support: while a SnapshotHold lives, Snapshot() of this map writes nothing and
  // prunes nothing (OK), so the store's chunks and journal stay as the hold's snapshot left
  // them; new writes still append to the journal. A hold is a counter, not a lock: it may
  // be released on any thread. REQUIRES: the map outlives its holds.
  class SnapshotHold {
   public:
    SnapshotHold(SnapshotHold&& o) noexcept : map_(std::exchange(o.map_, nullptr)) {}
    SnapshotHold& operator=(SnapshotHold&&) = delete;
    ~SnapshotHold() {
      if (map_ != nullptr) map_->snapshot_holds_.fetch_sub(1, std::memory_order_acq_rel);
    }

   private:
    friend class LiveMap;
    explicit SnapshotHold(LiveMap* map) : map_(map) {}
    LiveMap* map_;
  };
  // Writes a snapshot (as Snapshot(), even while other holds live) and returns a hold taken
  // right after it. Errors: Snapshot()'s; FailedPrecondition without a store.
  absl::StatusOr<SnapshotHold> SnapshotAndHold();
  // True while a SnapshotHold lives (the registry does not evict such a map).
  bool snapshots_held() const { return snapshot_holds_.load(std::memory_order_acquire) > 0; }

  // Journal records not yet covered by a snapshot, plus recognition results applied since
  // the last snapshot capture (they change volumes without a journal record).
  uint64_t records_since_snapshot() const {
    return journal_position_.load(std::memory_order_acquire) -
           snapshot_position_.load(std::memory_order_acquire) +
           recognition_changes_.load(std::memory_order_acquire);
  }

  // Recognition. OK when the map recognises objects or has recognition off; otherwise why
  // it does not (FailedPrecondition: no classifier, or objects missing from it).
  absl::Status recognition_status() const { return recognition_->status(); }
  // The model recognition uses; null when it does not run.
  const recognition::RecognitionModel* recognition_model() const { return recognition_->model(); }
  // Returns once every frame handed to recognition so far was processed.
  void FlushRecognition() { recognition_->Flush(); }
  // Instance events: `wake` runs (on the worker, under a mutex: it must only schedule
  // work) after new events were appended to the map's InstanceLog. Remove returns once
  // `wake` no longer runs.
  uint64_t AddInstanceWatcher(std::function<void()> wake);
  void RemoveInstanceWatcher(uint64_t id);
  // Map changes: `wake` runs (on the worker, under a mutex: it must only schedule work)
  // after each write that changed the map (an integrated frame, a pose update) and when
  // the map is deleted or evicted. Remove returns once `wake` no longer runs.
  uint64_t AddChangeWatcher(std::function<void()> wake);
  void RemoveChangeWatcher(uint64_t id);

  // Makes queued and future writes answer NotFound (the map left the registry); instance
  // watchers are woken to see it.
  void MarkDeleted() {
    deleted_.store(true, std::memory_order_release);
    NotifyWatchers();
    NotifyChangeWatchers();
  }
  // Makes queued and future writes answer Unavailable (the map was evicted from memory: a
  // retry reaches its reloaded copy).
  void MarkEvicted(bool evicted = true) {
    evicted_.store(evicted, std::memory_order_release);
    NotifyWatchers();
    NotifyChangeWatchers();
  }
  // OK, or the error writes get: NotFound after MarkDeleted, Unavailable after MarkEvicted.
  absl::Status Refused() const;
  // The pose of every integrated frame, by sequence (as of the writes queued before the
  // call; runs on the worker).
  std::vector<std::pair<uint64_t, perception::CameraPose>> Trajectory() {
    return queue_.Run([this] { return index_.Poses(); });
  }
  // Returns once the writes queued before the call have run.
  void Drain() {
    queue_.Run([] {});
  }

 private:
  // kAppend: a new write, appended to the journal before it is applied; kReplay: a write
  // read back from the journal at `position`.
  enum class Source { kAppend, kReplay };
  struct Capture;
  // A frame decoded ahead of the worker (live_map.cc).
  struct DecodeJob;
  // Starts decoding `frame` ahead: the header at once, depth and colour on the decoder.
  std::shared_ptr<DecodeJob> StartDecode(std::shared_ptr<const v1::Frame> frame);
  void StartDecodeParts(const std::shared_ptr<DecodeJob>& job);
  // Worker: the decoded frame of `job` (decoding what the decoder has not started), or the
  // first error of header, depth, colour.
  absl::Status FinishDecode(DecodeJob& job);
  // Image buffers of integrated frames, reused by the next decodes.
  perception::RgbdFrame TakeSpareFrame();
  void ReturnSpareFrame(perception::RgbdFrame frame);
  // A frame SubmitFrame queued (live_map_frames.cc).
  struct FrameWrite;
  // Worker thread only.
  // Integrates `first` and, with a store, the frames queued right behind it, then answers
  // each (its ack, or recognition's for the every-frame policy).
  void WriteFramesOnWorker(std::shared_ptr<FrameWrite> first);
  // Integrates `writes` in order and sets each one's ack (and `decoded`, for recognition,
  // when it runs and source is kAppend). Each frame is checked and decoded on its own: a
  // bad one gets its error and the others go on. The valid frames' records are appended to
  // the store at once (kAppend: one durable append) before any is applied; each frame is
  // applied as its own integration, all in one snapshot. kReplay: one frame, at `position`.
  void IntegrateOnWorker(std::span<FrameWrite* const> writes, Source source, uint64_t position);
  absl::StatusOr<v1::FrameAck> IntegrateOnWorker(std::shared_ptr<const v1::Frame> frame,
                                                 Source source, uint64_t position);
  v1::FrameAck MakeAck(uint64_t sequence, const perception::IntegrationStats& stats,
                       const WriteStats& written) const;
  absl::StatusOr<v1::UpdatePosesResponse> UpdatePosesOnWorker(const v1::UpdatePosesRequest& request,
                                                              Source source, uint64_t position);
  // `d` as a protobuf Duration (the timings of acks and responses).
  static void SetDuration(std::chrono::steady_clock::duration d, google::protobuf::Duration* out);
  absl::StatusOr<std::shared_ptr<const v1::Frame>> FrameOf(const FrameIndex::Entry& entry,
                                                           uint64_t sequence,
                                                           const std::string& field);
  absl::Status ReplayOnWorker(const storage::JournalRecord& record);
  std::unique_ptr<Capture> CaptureOnWorker();
  absl::Status SnapshotLocked();  // REQUIRES: snapshot_run_mu_ held
  absl::Status LoadSnapshotOnWorker();
  // Appends `records` to the store in one durable append; returns the last one's position
  // (0 without a store). The store's error otherwise, prefixed "journal: ": the writes must
  // then not be applied or acknowledged.
  absl::StatusOr<uint64_t> Journal(const std::vector<storage::JournalRecord>& records);
  // Stages `frame` (with frame.pose) in every stage; the first stage's counts. The stages
  // after the first may run on a decoder thread meanwhile; all are done on return.
  perception::IntegrationStats StageFrame(const perception::RgbdFrame& frame,
                                          FrameStage::Sign sign);
  // Applies every stage's staged changes under the exclusive lock; `frames_added` is added
  // to the frame counter and `position` becomes the state's journal position, in the same
  // snapshot. `also` (may be null) runs under the same lock. `per_sealed` (may be null):
  // each sealed frame's stats (FrameStage::Apply).
  WriteStats ApplyStages(uint64_t frames_added, uint64_t position,
                         const std::function<void(MapState&)>& also = nullptr,
                         std::vector<WriteStats>* per_sealed = nullptr);

  void NotifyWatchers();
  void NotifyChangeWatchers();
  std::string RetentionPolicy() const;

  const std::string id_;
  const uint64_t incarnation_;
  const Options options_;
  std::atomic<bool> deleted_{false};
  std::atomic<bool> evicted_{false};
  std::atomic<uint64_t> journal_position_{0};   // last record durable in the store
  std::atomic<uint64_t> snapshot_position_{0};  // what the last snapshot covers
  std::atomic<int64_t> snapshot_unix_ms_{0};
  std::atomic<uint64_t> pruned_position_{0};  // records up to here are pruned
  std::atomic<uint64_t> journal_bytes_{0};    // frame records kept (mirror of the index's)
  std::atomic<uint64_t> kept_frame_bytes_{0};

  mutable RwLock snapshot_mu_;
  MapState state_ ABSL_GUARDED_BY(snapshot_mu_);

  // Touched only on the worker thread (tasks of queue_ run one at a time).
  FrameIndex index_;
  uint64_t arrivals_ = 0;  // arrival order of frames in maps without a store
  std::vector<std::unique_ptr<FrameStage>> stages_;  // in order
  // Payload strings of the last group's journal records, up to 16 MB, which the next group
  // serializes into again (a megabyte each: new memory would fault its pages in).
  std::vector<std::string> journal_buffers_;

  Mutex spare_mu_;
  std::vector<perception::RgbdFrame> spare_frames_ ABSL_GUARDED_BY(spare_mu_);

  std::mutex snapshot_run_mu_;  // one Snapshot() at a time
  std::atomic<int> snapshot_holds_{0};

  // Changes recognition made without a journal record, since the last snapshot capture.
  std::atomic<uint64_t> recognition_changes_{0};
  std::mutex watchers_mu_;
  std::map<uint64_t, std::function<void()>> watchers_;         // guarded by watchers_mu_
  uint64_t next_watcher_ = 1;                                  // guarded by watchers_mu_
  std::map<uint64_t, std::function<void()>> change_watchers_;  // guarded by watchers_mu_

  WorkQueue queue_;  // destroyed before the members above, draining tasks while they live
  // The recognition stage (recognition/map_recognition.h). After queue_, so destroyed
  // before it: its jobs use the worker. ~LiveMap drains the worker first, then stops
  // this, then the worker goes.
  std::unique_ptr<MapRecognition> recognition_;
};

}  // namespace skimap::server

#endif  // SERVER_CORE_MAPS_LIVE_MAP_H_
