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
  // consecutive keys merge as in AddPoints, and a row's runs also merge into earlier items
  // of the same key (the rows above, most often), so that Finalize sorts a fraction of them:
  // on a robot's 640x480 frame at 2 cm (223 k points, 49 k distinct voxels) 53 k items
  // instead of 142 k runs. With a pool, rows are split over its threads
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

  // Makes this batch a copy of `other`'s items, finalized as `other` is, with room for
  // just those: what a built frame keeps while the batch it was built in builds the next.
  void CopyItemsFrom(const VoxelBatch& other) {
    Clear();
    Reserve(other.n_);
    std::copy(other.storage_.begin(), other.storage_.begin() + other.n_, storage_.begin());
    n_ = other.n_;
    rejected_ = other.rejected_;
    finalized_ = other.finalized_;
  }

  // Appends `items` to a finalized batch, which stays finalized.
  // REQUIRES: finalized(); keys strictly increasing in (x, y, z) order, the first one after
  // the batch's last, every component in [kMinKey, kMaxKey].
  void AppendSorted(std::span<const Item> items) {
    if (items.empty()) return;
    Reserve(n_ + items.size());
    std::copy(items.begin(), items.end(), storage_.begin() + n_);
    n_ += items.size();
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
  // One thread's row of AddRows, and its table of recent items.
  struct RowScratch {
    std::vector<int32_t> x, y, z;
    std::vector<uint8_t> state;
    std::vector<V> data;
    std::vector<uint32_t> recent;
  };
  // AddRows merges a row's runs with earlier items of the same key found through a small
  // direct-mapped table (kRecentSlots entries of 4 bytes: it stays in the L1 cache): an
  // image's neighbouring rows see the same voxels, so Finalize gets a fraction of the runs.
  static constexpr size_t kRecentBits = 13;
  static constexpr size_t kRecentSlots = size_t{1} << kRecentBits;
  static constexpr uint32_t kNoItem = ~uint32_t{0};
  static uint32_t RecentSlot(const VoxelKey& k) {
    const uint32_t h = static_cast<uint32_t>(k.x) * 0x9E3779B1u ^
                       static_cast<uint32_t>(k.y) * 0x85EBCA77u ^
                       static_cast<uint32_t>(k.z) * 0xC2B2AE3Du;
    return h >> (32 - kRecentBits);
  }
  // AddRows for rows [begin, end): the merged observations to out[0..) (keys may still
  // repeat: Finalize merges them); returns how many.
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

}  // namespace skimap

#include "skimap/voxel_batch_impl.h"  // IWYU pragma: export

#endif  // SKIMAP_VOXEL_BATCH_H_
