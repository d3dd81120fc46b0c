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
#include <array>
#include <bit>
#include <cstdint>
#include <span>
#include <type_traits>
#include <utility>
#include <vector>

#include "skimap/grid.h"
#include "skimap/voxel.h"

namespace skimap {

namespace internal {
// True for small trivially copyable voxels whose default value is all zero bits: they can
// be reset with a mask in the batch's hot loop.
template <class V>
consteval bool ZeroBytesDefault() {
  if constexpr (std::is_trivially_copyable_v<V> && sizeof(V) % 4 == 0 && sizeof(V) <= 32) {
    for (uint32_t w : std::bit_cast<std::array<uint32_t, sizeof(V) / 4>>(V{})) {
      if (w != 0) return false;
    }
    return true;
  } else {
    return false;
  }
}
template <class V>
inline constexpr bool kZeroBytesDefault = ZeroBytesDefault<V>();
}  // namespace internal

template <Voxel V>
class VoxelBatch {
 public:
  struct Item {
    VoxelKey key;
    V data;
  };

  void Clear() {
    n_ = 0;
    rejected_ = 0;
    finalized_ = true;
  }
  // Makes room for n items without reallocation.
  void Reserve(size_t n) {
    if (storage_.size() < n + 1) storage_.resize(std::max(n + 1, storage_.size() * 2));
  }

  // Adds one observation at world point (x, y, z). Returns false (and counts it as
  // rejected) when the point has no key in `grid`. For many points use AddPoints.
  bool Add(const Grid& grid, double x, double y, double z, const V& data) {
    const size_t before = rejected_;
    AddPoints(grid, 1, [&](size_t, Point3* p, V* d) {
      *p = {x, y, z};
      *d = data;
      return true;
    });
    return rejected_ == before;
  }

  // Adds `count` observations; get(i, Point3* p, V* data) fills point i and returns false
  // to skip it (e.g. a pixel without depth). Points without a key count as rejected.
  // The hot loop of frame integration: keep `get` cheap and inlinable.
  template <class Fn>
  void AddPoints(const Grid& grid, size_t count, Fn&& get);

  // REQUIRES: every component of `key` in [kMinKey, kMaxKey].
  void AddKey(const VoxelKey& key, const V& data) {
    AddPoints(Grid(1.0), 1, [&](size_t, Point3* p, V* d) {
      *p = {double(key.x), double(key.y), double(key.z)};
      *d = data;
      return true;
    });
  }

  // Sorts the items by key and merges duplicates. Cheap when already finalized.
  void Finalize();

  bool finalized() const { return finalized_; }
  // Items; sorted by key with unique keys once finalized().
  std::span<const Item> items() const { return {storage_.data() + 1, n_}; }
  size_t size() const { return n_; }
  bool empty() const { return n_ == 0; }
  size_t rejected() const { return rejected_; }

 private:
  // storage_[0] is a scratch slot (the pending run before the first item); items are
  // storage_[1 .. n_]; the rest is room to grow.
  std::vector<Item> storage_ = std::vector<Item>(1);
  size_t n_ = 0;
  std::vector<uint64_t> sort_a_, sort_b_;  // scratch, kept to avoid reallocation
  std::vector<uint32_t> counts_;
  std::vector<Item> merged_ = std::vector<Item>(1);
  size_t rejected_ = 0;
  bool finalized_ = true;
};

template <Voxel V>
template <class Fn>
void VoxelBatch<V>::AddPoints(const Grid& grid, size_t count, Fn&& get) {
  Reserve(n_ + count);
  // The run being accumulated (last, acc) lives in registers and is stored at out[n] after
  // every point; n advances only when the key changes. out[-1] is the scratch slot.
  Item* out = storage_.data() + 1;
  constexpr VoxelKey kNoKey{kMaxKey + 1, 0, 0};
  ptrdiff_t n = static_cast<ptrdiff_t>(n_) - 1;
  VoxelKey last = n >= 0 ? out[n].key : kNoKey;
  V acc = n >= 0 ? out[n].data : V{};
  for (size_t i = 0; i < count; ++i) {
    Point3 p;
    V d;
    if (!get(i, &p, &d)) continue;
    VoxelKey k;
    if (!grid.ToKey(p, &k)) {
      ++rejected_;
      continue;
    }
    const bool same = SameKey(k, last);
    out[n] = Item{last, acc};
    n += !same;
    if constexpr (internal::kZeroBytesDefault<V>) {
      // acc = same ? acc : V{}, with a mask instead of the branch GCC would emit.
      std::array<uint32_t, sizeof(V) / 4> words = std::bit_cast<decltype(words)>(acc);
      const uint32_t mask = 0u - static_cast<uint32_t>(same);
      for (uint32_t& w : words) w &= mask;
      acc = std::bit_cast<V>(words);
      acc += d;
    } else if (same) {
      acc += d;
    } else {
      acc = std::move(d);
    }
    last = k;
  }
  if (!SameKey(last, kNoKey)) out[n++] = Item{last, std::move(acc)};
  if (static_cast<size_t>(n) > n_ && n > 1) finalized_ = false;
  n_ = n < 0 ? 0 : static_cast<size_t>(n);  // n < 0: nothing was added to an empty batch
}

template <Voxel V>
void VoxelBatch<V>::Finalize() {
  if (finalized_) return;
  finalized_ = true;
  const size_t n = n_;
  const Item* items = storage_.data() + 1;
  VoxelKey lo = items[0].key, hi = items[0].key;
  for (size_t i = 0; i < n; ++i) {
    const VoxelKey& k = items[i].key;
    lo.x = std::min(lo.x, k.x), hi.x = std::max(hi.x, k.x);
    lo.y = std::min(lo.y, k.y), hi.y = std::max(hi.y, k.y);
    lo.z = std::min(lo.z, k.z), hi.z = std::max(hi.z, k.z);
  }
  auto bits = [](int32_t span) { return std::bit_width(static_cast<uint32_t>(span)); };
  const int bx = bits(hi.x - lo.x), by = bits(hi.y - lo.y), bz = bits(hi.z - lo.z);
  const int ib = std::bit_width(n - 1);
  const int kb = bx + by + bz;
  sort_a_.resize(n);
  uint64_t index_mask = ~uint64_t{0};
  if (kb + ib <= 64) {
    // Key relative to the box, index in the low bits. LSD radix sort on the key bits only:
    // stable, so equal keys keep their insertion order. Histograms of all digits are
    // taken in one sweep.
    index_mask = ib == 64 ? ~uint64_t{0} : (uint64_t{1} << ib) - 1;
    constexpr int kMaxDigitBits = 12;
    const int passes = kb == 0 ? 0 : (kb + kMaxDigitBits - 1) / kMaxDigitBits;
    const int digit = passes == 0 ? 0 : (kb + passes - 1) / passes;
    const uint64_t digit_mask = (uint64_t{1} << digit) - 1;
    std::vector<uint32_t>& count = counts_;
    count.assign(size_t(passes) << digit, 0);
    for (size_t i = 0; i < n; ++i) {
      const VoxelKey& k = items[i].key;
      const uint64_t rel =
          (uint64_t(k.x - lo.x) << (by + bz)) | (uint64_t(k.y - lo.y) << bz) | uint64_t(k.z - lo.z);
      sort_a_[i] = (rel << ib) | i;
      for (int p = 0; p < passes; ++p)
        ++count[(size_t(p) << digit) + ((rel >> (p * digit)) & digit_mask)];
    }
    sort_b_.resize(n);
    for (int p = 0; p < passes; ++p) {
      uint32_t* c = count.data() + (size_t(p) << digit);
      uint32_t sum = 0;
      for (size_t d = 0; d <= digit_mask; ++d) sum += std::exchange(c[d], sum);
      const int shift = ib + p * digit;
      for (uint64_t v : sort_a_) sort_b_[c[(v >> shift) & digit_mask]++] = v;
      sort_a_.swap(sort_b_);
    }
  } else {
    // Keys spanning most of the key range: comparison sort on (packed key, index).
    std::vector<std::pair<uint64_t, uint32_t>> order(n);
    for (size_t i = 0; i < n; ++i) order[i] = {PackKey(items[i].key), static_cast<uint32_t>(i)};
    std::sort(order.begin(), order.end());
    for (size_t i = 0; i < n; ++i) sort_a_[i] = order[i].second;
  }
  if (merged_.size() < storage_.size()) merged_.resize(storage_.size());
  Item* out = merged_.data() + 1;
  size_t m = 0;
  for (uint64_t v : sort_a_) {
    const Item& it = items[v & index_mask];
    if (m > 0 && SameKey(out[m - 1].key, it.key)) {
      out[m - 1].data += it.data;
    } else {
      out[m++] = it;
    }
  }
  storage_.swap(merged_);
  n_ = m;
}

}  // namespace skimap

#endif  // SKIMAP_VOXEL_BATCH_H_
