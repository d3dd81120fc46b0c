// VoxelBatch<V>: observations grouped per voxel before they touch the map.
//
//   VoxelBatch<RGBWeightedVoxel> batch;
//   for (point p : frame) batch.Add(map.grid(), p.x, p.y, p.z, RGBWeightedVoxel(r, g, b, 1));
//   batch.Finalize();              // sort by key, merge duplicates (data summed with +=)
//   map.Integrate(batch);          // one tree update per distinct voxel
//
// AddPoints() merges a point into the previous entry when both fall in the same voxel
// (image rows are coherent, so this removes most duplicates for free). Finalize() sorts
// with an LSD radix sort on the keys relative to the batch's bounding box (O(n)) and merges
// equal keys. Points without a key (outside the key range, NaN) are counted in rejected()
// and dropped. Given a ThreadPool, both split the work over its threads (AddPoints by
// point ranges, Finalize by x ranges of the keys).
//
// Thread safety: a batch is a single-threaded value (it uses the pool's threads itself).
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

#include "base/thread_pool.h"
#include "skimap/grid.h"
#include "skimap/key_sort.h"
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
// std::allocator whose resize() leaves new elements uninitialised instead of zeroing them:
// for the batch's buffers of trivially copyable items, every one of which is written before
// it is read. A fresh batch then does not clear (and fault in) room for a whole image.
template <class T>
struct UninitializedAllocator : std::allocator<T> {
  static_assert(std::is_trivially_copyable_v<T> && std::is_trivially_destructible_v<T>);
  template <class U>
  struct rebind {
    using other = UninitializedAllocator<U>;
  };
  UninitializedAllocator() = default;
  template <class U>
  UninitializedAllocator(const UninitializedAllocator<U>&) noexcept {}
  template <class U>
  void construct(U*) noexcept {}
  template <class U, class... Args>
  void construct(U* p, Args&&... args) {
    ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
  }
};
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
    if (storage_.size() < n) storage_.resize(std::max(n, storage_.size() * 2));
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
  // The hot loop of frame integration: keep `get` cheap and inlinable. With a pool, `get`
  // is called concurrently for different i and must be safe for that.
  template <class Fn>
  void AddPoints(const Grid& grid, size_t count, Fn&& get, ThreadPool* pool = nullptr);

  // One row of keyed observations for AddRows: for column c, its key (x[c], y[c], z[c])
  // and state[c]: kUse, kSkip (no observation, e.g. a pixel without depth) or kNoKey (a
  // point outside the key range: skipped and counted in rejected()).
  enum RowState : uint8_t { kSkip = 0, kUse = 1, kNoKey = 2 };
  struct KeyRow {
    int32_t* __restrict x;
    int32_t* __restrict y;
    int32_t* __restrict z;
    uint8_t* __restrict state;
  };
  // Adds rows x cols observations (an image) row by row: fill_row(r, KeyRow row, V* data)
  // fills row r's `cols` keys, states and data (perception/row_projection.h computes a
  // depth row's keys 4 pixels at a time: the row's arrays are separate). Equal
  // consecutive keys merge as in AddPoints. With a pool, rows are split over its threads
  // and fill_row is called concurrently for different rows. Scratch rows are kept in the
  // batch (no allocation once they have grown to `cols`).
  template <class RowFn>
  void AddRows(size_t rows, size_t cols, RowFn&& fill_row, ThreadPool* pool = nullptr);

  // REQUIRES: every component of `key` in [kMinKey, kMaxKey].
  void AddKey(const VoxelKey& key, const V& data) {
    AddPoints(Grid(1.0), 1, [&](size_t, Point3* p, V* d) {
      *p = {double(key.x), double(key.y), double(key.z)};
      *d = data;
      return true;
    });
  }

  // Appends items (typically another batch's) as observations; Finalize merges them with
  // the rest. Accumulates several frames into one batch.
  void AddItems(std::span<const Item> items) {
    if (items.empty()) return;
    Reserve(n_ + items.size());
    std::copy(items.begin(), items.end(), storage_.begin() + n_);
    n_ += items.size();
    finalized_ = false;
  }

  // Replaces the content with `items`, finalized without sorting.
  // REQUIRES: keys strictly increasing in (x, y, z) order, every component in
  // [kMinKey, kMaxKey] (what a finalized batch holds).
  void AssignSorted(std::span<const Item> items) {
    Clear();
    Reserve(items.size());
    std::copy(items.begin(), items.end(), storage_.begin());
    n_ = items.size();
  }

  // Sorts the items by key and merges duplicates, on the pool's threads if given. Cheap
  // when already finalized.
  void Finalize(ThreadPool* pool = nullptr);

  bool finalized() const { return finalized_; }
  // Items; sorted by key with unique keys once finalized().
  std::span<const Item> items() const { return {storage_.data(), n_}; }
  size_t size() const { return n_; }
  bool empty() const { return n_ == 0; }
  size_t rejected() const { return rejected_; }

 private:
  // Below these sizes the pool is not worth waking up.
  static constexpr size_t kParallelMinPoints = 1 << 14;
  static constexpr size_t kParallelMinItems = 1 << 14;

  // Run-merges observations as they come: the open run (last, acc) of equal consecutive
  // keys is stored at out[n] after every point and n advances only when the key changes
  // (a store per point instead of a branch on the key). Add() the points, then Finish().
  struct RunWriter {
    Item* out;
    size_t n = 0;
    bool open = false;
    VoxelKey last;
    V acc{};

    void Add(const VoxelKey& k, V d) {
      if (!open) {
        open = true;
        last = k;
        acc = std::move(d);
        return;
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
    // How many items were written to out[0..).
    size_t Finish() {
      if (!open) return 0;
      out[n] = Item{last, std::move(acc)};
      return n + 1;
    }
  };
  // Writes the run-merged observations of points [begin, end) to out[0..) and returns how
  // many; counts rejected points in *rejected.
  template <class Fn>
  static size_t AddRange(const Grid& grid, size_t begin, size_t end, Fn& get, Item* out,
                         size_t* rejected);
  // One thread's row of AddRows.
  struct RowScratch {
    std::vector<int32_t> x, y, z;
    std::vector<uint8_t> state;
    std::vector<V> data;
  };
  // AddRows for rows [begin, end): the run-merged observations to out[0..); returns how
  // many.
  template <class RowFn>
  static size_t AddRowRange(size_t begin, size_t end, size_t cols, RowFn& fill_row,
                            RowScratch& scratch, Item* out, size_t* rejected);
  // Merges the items that `sorted` (sort keys) orders into out[0..); returns how many.
  static size_t MergeSorted(const Item* items, const uint64_t* sorted, size_t count,
                            uint64_t index_mask, Item* out);

  // Items: uninitialised room for trivially copyable voxels, value-initialised otherwise.
  using Items = std::conditional_t<std::is_trivially_copyable_v<Item>,
                                   std::vector<Item, internal::UninitializedAllocator<Item>>,
                                   std::vector<Item>>;
  Items storage_;  // items are storage_[0 .. n_); the rest is room to grow
  size_t n_ = 0;
  // Scratch, kept to avoid reallocation.
  std::vector<uint64_t, internal::UninitializedAllocator<uint64_t>> sort_a_, sort_b_;
  Items merged_;
  std::vector<RowScratch> row_scratch_;  // one per AddRows piece, kept
  size_t rejected_ = 0;
  bool finalized_ = true;
};

template <Voxel V>
template <class Fn>
size_t VoxelBatch<V>::AddRange(const Grid& grid, size_t begin, size_t end, Fn& get, Item* out,
                               size_t* rejected) {
  RunWriter runs{out};
  for (size_t i = begin; i < end; ++i) {
    Point3 p;
    V d;
    if (!get(i, &p, &d)) continue;
    VoxelKey k;
    if (!grid.ToKey(p, &k)) {
      ++*rejected;
      continue;
    }
    runs.Add(k, std::move(d));
  }
  return runs.Finish();
}

template <Voxel V>
template <class Fn>
void VoxelBatch<V>::AddPoints(const Grid& grid, size_t count, Fn&& get, ThreadPool* pool) {
  Reserve(n_ + count);
  Item* out = storage_.data() + n_;
  size_t added = 0;
  if (pool == nullptr || pool->workers() == 0 || count < kParallelMinPoints) {
    added = AddRange(grid, 0, count, get, out, &rejected_);
  } else {
    // Piece p writes its runs at out + begin_p (room for every point), then the pieces are
    // moved together.
    const size_t pieces = static_cast<size_t>(pool->workers()) + 1;
    std::vector<size_t> written(pieces), rejected(pieces);
    pool->ParallelFor(pieces, [&](size_t first, size_t last) {
      for (size_t p = first; p < last; ++p) {
        const size_t begin = p * count / pieces, end = (p + 1) * count / pieces;
        written[p] = AddRange(grid, begin, end, get, out + begin, &rejected[p]);
      }
    });
    for (size_t p = 0; p < pieces; ++p) {
      const size_t begin = p * count / pieces;
      if (begin != added) std::move(out + begin, out + begin + written[p], out + added);
      added += written[p];
      rejected_ += rejected[p];
    }
  }
  n_ += added;
  if (added > 0 && n_ > 1) finalized_ = false;
}

template <Voxel V>
template <class RowFn>
size_t VoxelBatch<V>::AddRowRange(size_t begin, size_t end, size_t cols, RowFn& fill_row,
                                  RowScratch& s, Item* out, size_t* rejected) {
  RunWriter runs{out};
  size_t no_key = 0;
  for (size_t r = begin; r < end; ++r) {
    fill_row(r, KeyRow{s.x.data(), s.y.data(), s.z.data(), s.state.data()}, s.data.data());
    for (size_t c = 0; c < cols; ++c) {
      const uint8_t state = s.state[c];
      if (state != kUse) {
        no_key += state == kNoKey;
        continue;
      }
      runs.Add(VoxelKey{s.x[c], s.y[c], s.z[c]}, s.data[c]);
    }
  }
  *rejected += no_key;
  return runs.Finish();
}

template <Voxel V>
template <class RowFn>
void VoxelBatch<V>::AddRows(size_t rows, size_t cols, RowFn&& fill_row, ThreadPool* pool) {
  const size_t count = rows * cols;
  Reserve(n_ + count);
  Item* out = storage_.data() + n_;
  const bool parallel = pool != nullptr && pool->workers() > 0 && count >= kParallelMinPoints;
  const size_t pieces = parallel ? static_cast<size_t>(pool->workers()) + 1 : 1;
  if (row_scratch_.size() < pieces) row_scratch_.resize(pieces);
  for (size_t p = 0; p < pieces; ++p) {
    RowScratch& s = row_scratch_[p];
    if (s.state.size() < cols) {
      s.x.resize(cols);
      s.y.resize(cols);
      s.z.resize(cols);
      s.state.resize(cols);
      s.data.resize(cols);
    }
  }
  size_t added = 0;
  if (!parallel) {
    added = AddRowRange(0, rows, cols, fill_row, row_scratch_[0], out, &rejected_);
  } else {
    // Piece p writes its runs at out + first row * cols (room for every point), then the
    // pieces are moved together, as in AddPoints.
    std::array<size_t, 64> written{}, rejected{};
    const size_t used = std::min(pieces, written.size());
    pool->ParallelFor(used, [&](size_t first, size_t last) {
      for (size_t p = first; p < last; ++p) {
        const size_t begin = p * rows / used, end = (p + 1) * rows / used;
        written[p] = AddRowRange(begin, end, cols, fill_row, row_scratch_[p], out + begin * cols,
                                 &rejected[p]);
      }
    });
    for (size_t p = 0; p < used; ++p) {
      const size_t begin = p * rows / used * cols;
      if (begin != added) std::move(out + begin, out + begin + written[p], out + added);
      added += written[p];
      rejected_ += rejected[p];
    }
  }
  n_ += added;
  if (added > 0 && n_ > 1) finalized_ = false;
}

template <Voxel V>
size_t VoxelBatch<V>::MergeSorted(const Item* items, const uint64_t* sorted, size_t count,
                                  uint64_t index_mask, Item* out) {
  // The items are read in sorted order, i.e. at random: prefetching a few ahead overlaps
  // those cache misses.
  constexpr size_t kAhead = 16;
  size_t m = 0;
  for (size_t i = 0; i < count; ++i) {
    if (i + kAhead < count) __builtin_prefetch(&items[sorted[i + kAhead] & index_mask]);
    const Item& it = items[sorted[i] & index_mask];
    if (m > 0 && SameKey(out[m - 1].key, it.key)) {
      out[m - 1].data += it.data;
    } else {
      out[m++] = it;
    }
  }
  return m;
}

template <Voxel V>
void VoxelBatch<V>::Finalize(ThreadPool* pool) {
  if (finalized_) return;
  finalized_ = true;
  const size_t n = n_;
  const Item* items = storage_.data();
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
  sort_b_.resize(n);
  if (merged_.size() < storage_.size()) merged_.resize(storage_.size());
  if (kb + ib > 64) {
    // Keys spanning most of the key range: comparison sort on (packed key, index).
    std::vector<std::pair<uint64_t, uint32_t>> order(n);
    for (size_t i = 0; i < n; ++i) order[i] = {PackKey(items[i].key), static_cast<uint32_t>(i)};
    std::sort(order.begin(), order.end());
    for (size_t i = 0; i < n; ++i) sort_a_[i] = order[i].second;
    n_ = MergeSorted(items, sort_a_.data(), n, ~uint64_t{0}, merged_.data());
    storage_.swap(merged_);
    return;
  }
  // Sort key: voxel key relative to the box (x major), index in the low bits.
  const uint64_t index_mask = (uint64_t{1} << ib) - 1;
  for (size_t i = 0; i < n; ++i) {
    const VoxelKey& k = items[i].key;
    const uint64_t rel =
        (uint64_t(k.x - lo.x) << (by + bz)) | (uint64_t(k.y - lo.y) << bz) | uint64_t(k.z - lo.z);
    sort_a_[i] = (rel << ib) | i;
  }
  if (pool == nullptr || pool->workers() == 0 || n < kParallelMinItems || bx == 0) {
    const uint64_t* sorted = internal::RadixSort(sort_a_.data(), sort_b_.data(), n, ib, kb);
    n_ = MergeSorted(items, sorted, n, index_mask, merged_.data());
    storage_.swap(merged_);
    return;
  }
  // Split by x into one range per thread, sort and merge each range on its own thread,
  // then move the merged ranges together.
  const size_t parts = static_cast<size_t>(pool->workers()) + 1;
  const std::vector<size_t> offsets = internal::PartitionByTopBits(
      sort_a_.data(), sort_b_.data(), n, ib, kb, std::min(bx, 16), parts);
  std::vector<size_t> merged(parts);
  pool->ParallelFor(parts, [&](size_t first, size_t last) {
    for (size_t p = first; p < last; ++p) {
      const size_t begin = offsets[p], count = offsets[p + 1] - begin;
      const uint64_t* sorted =
          internal::RadixSort(sort_b_.data() + begin, sort_a_.data() + begin, count, ib, kb);
      merged[p] = MergeSorted(items, sorted, count, index_mask, merged_.data() + begin);
    }
  });
  size_t m = 0;
  for (size_t p = 0; p < parts; ++p) {
    Item* src = merged_.data() + offsets[p];
    if (src != merged_.data() + m) std::move(src, src + merged[p], merged_.data() + m);
    m += merged[p];
  }
  n_ = m;
  storage_.swap(merged_);
}

}  // namespace skimap

#endif  // SKIMAP_VOXEL_BATCH_H_
