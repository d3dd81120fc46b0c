#include "server/core/maps/frame_index.h"

#include <cmath>

#include "absl/strings/str_cat.h"
#include "base/encoding.h"
#include "server/core/transfer/chunk_codec.h"

namespace skimap::server {
namespace {

// Entry layout in a frame-index chunk (little endian): u64 sequence, u64 position,
// u64 record bytes, pose as 7 f64 (qw, qx, qy, qz, tx, ty, tz): 80 bytes (type 1);
// type 2 adds u8 flags (bit 0: recognised): 81 bytes. Type 1 chunks are still read.
constexpr uint32_t kEntryTypeV1 = 1;
constexpr uint32_t kEntryType = 2;
constexpr size_t kEntryBytesV1 = 8 * 3 + 7 * 8;
constexpr size_t kEntryBytes = kEntryBytesV1 + 1;
constexpr uint8_t kRecognized = 1;

int64_t BucketOf(uint64_t sequence) {
  return static_cast<int64_t>(sequence >> FrameIndex::kBucketShift);
}

}  // namespace

const FrameIndex::Entry* FrameIndex::Find(uint64_t sequence) const {
  auto it = entries_.find(sequence);
  return it == entries_.end() ? nullptr : &it->second;
}

void FrameIndex::Add(uint64_t sequence, Entry entry) {
  if (entry.frame != nullptr) kept_bytes_ += entry.record_bytes;
  if (entry.position > pruned_upto_) journal_bytes_ += entry.record_bytes;
  by_position_[entry.position] = sequence;
  entries_[sequence] = std::move(entry);
  dirty_.insert(BucketOf(sequence));
}

void FrameIndex::SetRecognized(uint64_t sequence) {
  Entry& e = entries_.at(sequence);
  if (e.recognized) return;
  e.recognized = true;
  ++recognized_;
  dirty_.insert(BucketOf(sequence));
}

void FrameIndex::ClearRecognized() {
  for (auto& [sequence, e] : entries_) {
    if (!e.recognized) continue;
    e.recognized = false;
    dirty_.insert(BucketOf(sequence));
  }
  recognized_ = 0;
}

void FrameIndex::SetPose(uint64_t sequence, const perception::CameraPose& pose) {
  entries_.at(sequence).pose = pose;
  dirty_.insert(BucketOf(sequence));
}

void FrameIndex::LimitKeptFrames(size_t max_bytes) {
  for (auto it = by_position_.begin(); kept_bytes_ > max_bytes && it != by_position_.end(); ++it) {
    Entry& e = entries_.at(it->second);
    if (e.frame == nullptr) continue;
    kept_bytes_ -= e.record_bytes;
    e.frame.reset();
  }
}

uint64_t FrameIndex::RetentionCut(uint64_t covered, uint64_t budget) const {
  uint64_t bytes = journal_bytes_;
  uint64_t cut = pruned_upto_;
  for (auto it = by_position_.upper_bound(pruned_upto_);
       bytes > budget && it != by_position_.end() && it->first <= covered; ++it) {
    bytes -= entries_.at(it->second).record_bytes;
    cut = it->first;
  }
  return cut;
}

void FrameIndex::MarkPruned(uint64_t upto) {
  for (auto it = by_position_.upper_bound(pruned_upto_);
       it != by_position_.end() && it->first <= upto; ++it) {
    journal_bytes_ -= entries_.at(it->second).record_bytes;
  }
  if (upto > pruned_upto_) pruned_upto_ = upto;
}

std::vector<int64_t> FrameIndex::TakeDirty() {
  std::vector<int64_t> out(dirty_.begin(), dirty_.end());
  dirty_.clear();
  return out;
}

void FrameIndex::MarkDirty(const std::vector<int64_t>& buckets) {
  dirty_.insert(buckets.begin(), buckets.end());
}

std::string FrameIndex::EncodeBucket(int64_t bucket) const {
  const uint64_t first = static_cast<uint64_t>(bucket) << kBucketShift;
  const uint64_t last = first + ((uint64_t{1} << kBucketShift) - 1);
  std::string raw;
  Encoder e(&raw);
  uint32_t count = 0;
  for (auto it = entries_.lower_bound(first); it != entries_.end() && it->first <= last; ++it) {
    const Entry& x = it->second;
    e.U64(it->first);
    e.U64(x.position);
    e.U64(x.record_bytes);
    for (double v :
         {x.pose.rotation.w(), x.pose.rotation.x(), x.pose.rotation.y(), x.pose.rotation.z(),
          x.pose.translation.x(), x.pose.translation.y(), x.pose.translation.z()}) {
      e.F64(v);
    }
    e.U8(x.recognized ? kRecognized : 0);
    ++count;
  }
  return SealChunk(ChunkContent::kFrameIndex, kEntryType, count, std::move(raw));
}

absl::Status FrameIndex::DecodeBucket(int64_t bucket, std::string_view blob) {
  absl::StatusOr<OpenedChunk> opened = OpenChunk(blob, ChunkContent::kFrameIndex, kAnyChunkType);
  if (!opened.ok()) return opened.status();
  if (opened->type != kEntryType && opened->type != kEntryTypeV1) {
    return absl::DataLossError(
        absl::StrCat("frame index chunk: unknown entry type ", opened->type));
  }
  const bool v1 = opened->type == kEntryTypeV1;
  if (opened->raw.size() != size_t{opened->count} * (v1 ? kEntryBytesV1 : kEntryBytes)) {
    return absl::DataLossError("frame index chunk: size does not match its entry count");
  }
  Decoder d(opened->raw);
  for (uint32_t i = 0; i < opened->count; ++i) {
    uint64_t sequence = 0;
    Entry x;
    double q[4], t[3];
    uint8_t flags = 0;
    (void)(d.U64(&sequence) && d.U64(&x.position) && d.U64(&x.record_bytes) && d.F64(&q[0]) &&
           d.F64(&q[1]) && d.F64(&q[2]) && d.F64(&q[3]) && d.F64(&t[0]) && d.F64(&t[1]) &&
           d.F64(&t[2]) && (v1 || d.U8(&flags)));
    x.recognized = (flags & kRecognized) != 0;
    x.pose.rotation = Eigen::Quaterniond(q[0], q[1], q[2], q[3]);
    x.pose.translation = {t[0], t[1], t[2]};
    if (BucketOf(sequence) != bucket || entries_.contains(sequence) ||
        by_position_.contains(x.position) || !perception::ValidatePose(x.pose).ok()) {
      return absl::DataLossError(absl::StrCat("frame index chunk ", bucket, ": entry ", i,
                                              " is invalid (sequence ", sequence, ")"));
    }
    const bool recognized = x.recognized;
    x.recognized = false;
    Add(sequence, std::move(x));
    if (recognized) SetRecognized(sequence);
  }
  return absl::OkStatus();
}

}  // namespace skimap::server
