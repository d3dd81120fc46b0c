// FrameIndex: what a map knows about each frame it integrated, by sequence: where the
// frame's record is in the journal, its size, the pose it is integrated with now (after
// pose updates), and, for maps without a store, the encoded frame itself (kept up to a
// memory budget). UpdatePoses reads frames back through it; snapshots persist it as
// frame-index chunks of 4096 sequences each (docs/formats.md), so sequences, poses and
// journal positions survive restarts.
//
//   FrameIndex index;
//   index.Add(7, {.position = 12, .record_bytes = 480000, .pose = pose});
//   const FrameIndex::Entry* e = index.Find(7);
//
// Retention: RetentionCut(covered, budget) is the journal position up to which frame
// records may be pruned so that the frame records left weigh at most `budget` bytes,
// never beyond `covered` (what a snapshot covers). MarkPruned records the cut; entries
// whose position is at or before it have no frame any more.
//
// Thread safety: a single-threaded value (the map's worker owns it).
#ifndef SERVER_CORE_MAPS_FRAME_INDEX_H_
#define SERVER_CORE_MAPS_FRAME_INDEX_H_

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "absl/container/flat_hash_set.h"
#include "absl/status/status.h"
#include "perception/rgbd_frame.h"
#include "skimap/v1/frames.pb.h"

namespace skimap::server {

class FrameIndex {
 public:
  struct Entry {
    uint64_t position = 0;      // journal position of the frame's record (or arrival order)
    uint64_t record_bytes = 0;  // size of that record (or of the kept frame)
    perception::CameraPose pose;
    std::shared_ptr<const v1::Frame> frame;  // in memory (maps without a store); may be null
    bool recognized = false;  // its labels are in the map's labels volume (with `pose`)
  };
  static constexpr int kBucketShift = 12;  // sequences per frame-index chunk: 4096

  size_t size() const { return entries_.size(); }
  bool Contains(uint64_t sequence) const { return entries_.contains(sequence); }
  const Entry* Find(uint64_t sequence) const;
  // The frames' poses, by sequence.
  std::vector<std::pair<uint64_t, perception::CameraPose>> Poses() const {
    std::vector<std::pair<uint64_t, perception::CameraPose>> poses;
    poses.reserve(entries_.size());
    for (const auto& [sequence, entry] : entries_) poses.emplace_back(sequence, entry.pose);
    return poses;
  }
  // REQUIRES: !Contains(sequence) and entry.position above every earlier one.
  void Add(uint64_t sequence, Entry entry);
  // REQUIRES: Contains(sequence).
  void SetPose(uint64_t sequence, const perception::CameraPose& pose);
  // Marks the frame recognised (REQUIRES: Contains(sequence)); recognized() counts them.
  void SetRecognized(uint64_t sequence);
  uint64_t recognized() const { return recognized_; }
  // Marks every frame not recognised (their labels were dropped).
  void ClearRecognized();

  // Maps without a store: drops kept frames, oldest first, until they weigh <= max_bytes.
  void LimitKeptFrames(size_t max_bytes);
  size_t kept_frame_bytes() const { return kept_bytes_; }

  // Retention (see above).
  uint64_t RetentionCut(uint64_t covered, uint64_t budget) const;
  void MarkPruned(uint64_t upto);
  uint64_t pruned_upto() const { return pruned_upto_; }
  bool Pruned(const Entry& e) const { return e.position <= pruned_upto_; }
  // Bytes of frame records not pruned.
  uint64_t journal_bytes() const { return journal_bytes_; }

  // Snapshot support: the buckets changed since the last TakeDirty, and their blobs.
  std::vector<int64_t> TakeDirty();
  void MarkDirty(const std::vector<int64_t>& buckets);
  std::string EncodeBucket(int64_t bucket) const;
  // Adds the entries of one bucket blob (validated: sequences in the bucket, finite unit
  // poses). DataLoss / FailedPrecondition from the chunk codec.
  absl::Status DecodeBucket(int64_t bucket, std::string_view blob);

 private:
  std::map<uint64_t, Entry> entries_;         // by sequence
  std::map<uint64_t, uint64_t> by_position_;  // position -> sequence
  absl::flat_hash_set<int64_t> dirty_;        // buckets
  uint64_t pruned_upto_ = 0;
  uint64_t journal_bytes_ = 0;
  size_t kept_bytes_ = 0;
  uint64_t recognized_ = 0;
};

}  // namespace skimap::server

#endif  // SERVER_CORE_MAPS_FRAME_INDEX_H_
