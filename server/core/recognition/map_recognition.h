// MapRecognition: the recognition stage of one map (docs/recognition.md). Its
// RecognitionQueue's first thread turns an integrated frame into label observations; the
// second fuses them into the labels volume with the frame's current pose, votes for local
// hypotheses in the active sphere and reconciles the instances (instance_reconciler.h).
// Every change of the MapState runs on the map's worker, under the map's snapshot lock.
// UpdatePoses moves a recognised frame's labels and hypotheses with it (StageMove, then
// ApplyMoves under the write's lock).
//
//   MapRecognition r({.map_id = id, .config = &config, .classifier = db},
//                    {.mu = &mu, .state = &state, .index = &index, .worker = &queue, ...});
//   r.Offer(sequence, frame, decoded, done);  // on the worker, after integrating
//
// A map with recognition off, or whose classifier is missing or lacks its objects, gets a
// MapRecognition that does not run (status() says why); it still restores the recognition
// bookkeeping of a loaded map (AfterLoad) and moves nothing on UpdatePoses.
//
// Thread safety: Offer, StageMove, ApplyMoves and AfterLoad run on the map's worker; the
// queue's threads run the rest; status(), model(), recognized_frames(), skipped() and Flush
// are thread safe. Stop() before the worker goes (the last job may still use it).
#ifndef SERVER_CORE_RECOGNITION_MAP_RECOGNITION_H_
#define SERVER_CORE_RECOGNITION_MAP_RECOGNITION_H_

#include <atomic>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/status/status.h"
#include "base/rw_lock.h"
#include "perception/objects/object_database.h"
#include "perception/recognition/active_sphere.h"
#include "perception/recognition/label_observer.h"
#include "perception/recognition/pose_voting.h"
#include "perception/recognition/recognition_model.h"
#include "perception/rgbd_frame.h"
#include "server/core/common/work_queue.h"
#include "server/core/maps/frame_index.h"
#include "server/core/maps/map_config.h"
#include "server/core/maps/map_state.h"
#include "server/core/metrics/metrics.h"
#include "server/core/recognition/recognition_queue.h"
#include "server/core/recognition/view_keyframes.h"
#include "skimap/v1/frames.pb.h"

namespace skimap::server {

class MapRecognition {
 public:
  struct Options {
    std::string map_id;
    const MapConfig* config = nullptr;  // the map's; outlives this
    int worker_nice = 0;                // the map worker's niceness
    // The object database, asked once here (null, or returning null: no recognition).
    std::function<std::shared_ptr<const objects::ObjectDatabase>()> classifier;
    Metrics* metrics = nullptr;  // recognised frames; null: none
  };
  // The map's parts recognition works on (LiveMap's; not owned, they outlive this).
  struct Map {
    RwLock* mu = nullptr;                   // the snapshot lock: held exclusively for every change
    MapState* state = nullptr;              // guarded by *mu
    FrameIndex* index = nullptr;            // worker only
    WorkQueue* worker = nullptr;            // the map's worker
    std::function<absl::Status()> refused;  // non-OK: the map is gone, stop working on it
    std::function<void()> instances_changed;   // on the worker, after instance events
    std::atomic<uint64_t>* changes = nullptr;  // +1 per change made without a journal record
  };

  MapRecognition(const Options& options, const Map& map);
  MapRecognition(const MapRecognition&) = delete;
  MapRecognition& operator=(const MapRecognition&) = delete;

  // OK when the map recognises objects or has recognition off; otherwise why it does not
  // (FailedPrecondition: no classifier, or objects missing from it).
  const absl::Status& status() const { return status_; }
  // The model recognition uses; null when it does not run.
  const recognition::RecognitionModel* model() const { return model_.get(); }
  bool running() const { return queue_ != nullptr; }
  uint64_t recognized_frames() const { return recognized_frames_.load(std::memory_order_acquire); }
  uint64_t skipped() const { return queue_ != nullptr ? queue_->skipped() : 0; }
  // Returns once every frame offered so far was processed.
  void Flush();
  // Stops the queue's threads (their jobs' `done` still run). Idempotent.
  void Stop() { queue_.reset(); }

  // Worker: hands an integrated frame to recognition; true if `done` was taken over (the
  // every-frame policy acks after recognition). False (done not taken) when not running.
  bool Offer(uint64_t sequence, const v1::Frame& frame,
             std::shared_ptr<const perception::RgbdFrame> decoded,
             const std::function<void()>& done);
  // Worker, UpdatePoses: stages the moves of recognised frame `frame` (its labels and
  // hypotheses, from its old pose to its new one) for ApplyMoves.
  void StageMove(uint64_t sequence, const perception::RgbdFrame& frame,
                 const perception::CameraPose& old_pose, const perception::CameraPose& new_pose);
  // Worker, under the map's exclusive lock (`state` is the map's): applies the staged moves
  // and reconciles the moved objects' instances.
  void ApplyMoves(MapState& state);
  // Worker, after a load read the snapshot and journal: the recognition bookkeeping
  // (recognised frames, instance keys), and, when the classifier changed since the labels
  // were made, clears labels and hypotheses (instances stay).
  void AfterLoad();

 private:
  struct Voted {
    int object_index;
    recognition::PoseEstimate estimate;
  };
  void Start();
  void ObserveOnThread(RecognitionJob& job);    // the queue's first thread: job.observed
  void RecognizeOnThread(RecognitionJob& job);  // its second: labels, votes, instances
  // Worker: fuses a frame's labels with its current pose; nullopt if the frame is gone or
  // was recognised already.
  std::optional<perception::CameraPose> ApplyLabelsOnWorker(
      uint64_t sequence, const recognition::LabelObservations& observations);
  // Worker: adds a frame's hypotheses and reconciles the instances of their objects.
  void ApplyHypothesesOnWorker(const RecognitionJob& job, const perception::CameraPose& pose,
                               const recognition::Sphere& sphere, const std::vector<Voted>& voted);
  void Changed() { map_.changes->fetch_add(1, std::memory_order_acq_rel); }
  // The labels volume's grid: fixed when the map is made, so read without the lock.
  const Grid& labels_grid() const ABSL_NO_THREAD_SAFETY_ANALYSIS { return state_->labels.grid(); }

  const Options options_;
  const Map map_;
  RwLock* const mu_;
  MapState* const state_ ABSL_PT_GUARDED_BY(mu_);

  std::shared_ptr<const recognition::RecognitionModel> model_;  // null: not running
  absl::Status status_;
  std::unique_ptr<recognition::LabelObserver> worker_observer_;  // worker only
  std::unique_ptr<recognition::LabelObserver> thread_observer_;  // observing thread only
  VoxelBatch<MultiLabelVoxel> labels_add_, labels_remove_;       // worker only
  std::map<uint64_t, Eigen::Isometry3d> hypothesis_moves_;       // worker only: frame -> delta
  std::unique_ptr<ViewKeyframes> view_keyframes_;                // worker only
  std::atomic<uint64_t> recognized_frames_{0};
  std::unique_ptr<RecognitionQueue> queue_;  // last: its threads use the members above
};

}  // namespace skimap::server

#endif  // SERVER_CORE_RECOGNITION_MAP_RECOGNITION_H_
