// VoxelBatch<V>: observations grouped per voxel before they touch the map.
//
//   VoxelBatch<RGBWeightedVoxel> batch;
//   for (point p : frame) batch.Add(map.grid(), p.x, p.y, p.z, RGBWeightedVoxel(r, g, b, 1));
//   batch.Finalize();              // sort by key, merge duplicates (data summed with +=)
//   map.Integrate(batch);          // one tree update per distinct voxel
//
// Add() merges a point into the previous entry when both fall in the same voxel (image
// rows are coherent, so this removes most duplicates for free). Finalize() sorts with an
// LSD radix sort on the keys relative to the batch's bounding box (O(n), 11-bit digits)
// and merges equal keys. Points without a key (outside the key range, NaN) are counted
// in rejected() and dropped.
//
// Thread safety: a batch is a single-threaded value.
#ifndef SKIMAP_VOXEL_BATCH_H_
#define SKIMAP_VOXEL_BATCH_H_

#include <algorithm>
#include <bit>
#include <cstdint>
#include <vector>

#include "skimap/grid.h"
#include "skimap/voxel.h"

namespace skimap {

template <Voxel V>
class VoxelBatch {
 public:
  struct Item {
    VoxelKey key;
    V data;
  };

  void Clear() {
    items_.clear();
    rejected_ = 0;
    finalized_ = true;
  }
  void Reserve(size_t n) { items_.reserve(n); }

  // Adds one observation at world point (x, y, z). Returns false (and counts it as
  // rejected) when the point has no key in `grid`.
  bool Add(const Grid& grid, double x, double y, double z, const V& data) {
    VoxelKey key;
    if (!grid.ToKey(x, y, z, &key)) {
      ++rejected_;
      return false;
    }
    AddKey(key, data);
    return true;
  }
  // REQUIRES: every component of `key` in [kMinKey, kMaxKey].
  void AddKey(const VoxelKey& key, const V& data) {
    if (!items_.empty() && items_.back().key == key) {
      items_.back().data += data;
      return;
    }
    items_.push_back({key, data});
    finalized_ = items_.size() <= 1;
  }

  // Sorts the items by key and merges duplicates. Cheap when already finalized.
  void Finalize();

  bool finalized() const { return finalized_; }
  // Items; sorted by key with unique keys once finalized().
  const std::vector<Item>& items() const { return items_; }
  size_t size() const { return items_.size(); }
  bool empty() const { return items_.empty(); }
  size_t rejected() const { return rejected_; }

 private:
  std::vector<Item> items_;
  std::vector<uint64_t> sort_a_, sort_b_;  // scratch, kept to avoid reallocation
  std::vector<Item> merged_;
  size_t rejected_ = 0;
  bool finalized_ = true;
};

template <Voxel V>
void VoxelBatch<V>::Finalize() {
  if (finalized_) return;
  finalized_ = true;
  const size_t n = items_.size();
  VoxelKey lo = items_[0].key, hi = items_[0].key;
  for (const Item& it : items_) {
    lo.x = std::min(lo.x, it.key.x), hi.x = std::max(hi.x, it.key.x);
    lo.y = std::min(lo.y, it.key.y), hi.y = std::max(hi.y, it.key.y);
    lo.z = std::min(lo.z, it.key.z), hi.z = std::max(hi.z, it.key.z);
  }
  auto bits = [](int32_t span) { return std::bit_width(static_cast<uint32_t>(span)); };
  const int bx = bits(hi.x - lo.x), by = bits(hi.y - lo.y), bz = bits(hi.z - lo.z);
  const int ib = std::bit_width(n - 1);
  const int kb = bx + by + bz;
  sort_a_.resize(n);
  if (kb + ib <= 64) {
    // Key relative to the box, index in the low bits: sorting the key bits alone is
    // stable, so equal keys keep their insertion order.
    for (size_t i = 0; i < n; ++i) {
      const VoxelKey& k = items_[i].key;
      const uint64_t rel =
          (uint64_t(k.x - lo.x) << (by + bz)) | (uint64_t(k.y - lo.y) << bz) | uint64_t(k.z - lo.z);
      sort_a_[i] = (rel << ib) | i;
    }
    sort_b_.resize(n);
    constexpr int kDigit = 11;
    size_t count[1 << kDigit];
    for (int shift = ib; shift < ib + kb; shift += kDigit) {
      std::fill(std::begin(count), std::end(count), 0);
      for (uint64_t v : sort_a_) ++count[(v >> shift) & ((1 << kDigit) - 1)];
      size_t sum = 0;
      for (size_t& c : count) sum += std::exchange(c, sum);
      for (uint64_t v : sort_a_) sort_b_[count[(v >> shift) & ((1 << kDigit) - 1)]++] = v;
      sort_a_.swap(sort_b_);
    }
  } else {
    // Keys spanning most of the key range: comparison sort on (packed key, index).
    std::vector<std::pair<uint64_t, uint32_t>> order(n);
    for (size_t i = 0; i < n; ++i) order[i] = {PackKey(items_[i].key), static_cast<uint32_t>(i)};
    std::sort(order.begin(), order.end());
    for (size_t i = 0; i < n; ++i) sort_a_[i] = order[i].second;
  }
  const uint64_t index_mask = kb + ib <= 64 ? (ib == 64 ? ~0ull : (1ull << ib) - 1) : ~0ull;
  merged_.clear();
  merged_.reserve(n);
  for (uint64_t v : sort_a_) {
    const Item& it = items_[v & index_mask];
    if (!merged_.empty() && merged_.back().key == it.key) {
      merged_.back().data += it.data;
    } else {
      merged_.push_back(it);
    }
  }
  items_.swap(merged_);
}

}  // namespace skimap

#endif  // SKIMAP_VOXEL_BATCH_H_
