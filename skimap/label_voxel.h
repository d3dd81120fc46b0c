// MultiLabelVoxel: a multiset of class labels with counts (SkiMap++ Eq. 4-5).
//
//   V = {<l, w_l>},  V1 ± V2 = {<l, w1_l ± w2_l>}
//
// Merging is lossless: every label keeps its own count, so integrating then
// de-integrating the same labels restores the voxel exactly. Counts never go below zero
// (subtracting more than present clamps at zero) and zero-count labels are dropped.
// Entries are kept sorted by label; one or two labels are stored without heap memory.
#ifndef SKIMAP_LABEL_VOXEL_H_
#define SKIMAP_LABEL_VOXEL_H_

#include <cstdint>
#include <utility>

#include "absl/container/inlined_vector.h"
#include "base/encoding.h"

namespace skimap {

class MultiLabelVoxel {
 public:
  static constexpr uint32_t kTypeId = 3;
  struct Entry {
    uint32_t label;
    uint32_t count;
    friend bool operator==(const Entry&, const Entry&) = default;
  };

  MultiLabelVoxel() = default;
  // `count` observations of one label.
  explicit MultiLabelVoxel(uint32_t label, uint32_t count = 1) {
    if (count > 0) entries_.push_back({label, count});
  }

  MultiLabelVoxel& operator+=(const MultiLabelVoxel& o);
  MultiLabelVoxel& operator-=(const MultiLabelVoxel& o);

  // Count of one label (0 if absent).
  uint32_t Count(uint32_t label) const;
  // The label with the largest count (ties: the smaller label); {0, 0} when empty.
  Entry Heaviest() const;
  // Entries sorted by label, all counts > 0.
  const absl::InlinedVector<Entry, 2>& entries() const { return entries_; }

  bool IsEmpty() const { return entries_.empty(); }
  // Total count over all labels.
  float Weight() const;
  size_t HeapBytes() const {
    return entries_.capacity() > 2 ? entries_.capacity() * sizeof(Entry) : 0;
  }
  void Encode(Encoder& e) const;
  // Rejects unsorted, duplicate or zero-count entries.
  static bool Decode(Decoder& d, MultiLabelVoxel* v);

  friend bool operator==(const MultiLabelVoxel&, const MultiLabelVoxel&) = default;

 private:
  absl::InlinedVector<Entry, 2> entries_;
};

}  // namespace skimap

#endif  // SKIMAP_LABEL_VOXEL_H_
