// ZRow<V>: the z level of one (x, y) column of a SkiMap: its voxels as one sorted run of
// (z, value) entries in memory from the column's NodePool.
//
//   ZRow<RGBWeightedVoxel> row;
//   row.Integrate(pool, items, items + n, &stats, &heap_bytes);  // sorted, distinct z
//   for (const auto& e : row) ...                                 // ascending z
//   const auto* e = row.LowerBound(z);                            // O(log n)
//   row.Clear(pool);                                              // before destruction
//
// Why a run and not a third skip list: most (x, y) columns of a map hold a few voxels, and
// a skip list pays a node (key, height, link) and a pointer chase per voxel. A run keeps a
// column's voxels in one block: a batch merges into it in one pass (a search per item,
// one shift of the entries for all the new keys), and queries read neighbouring voxels
// from neighbouring memory. Access stays O(log n) by binary search, and the level stays
// ordered by key.
//
// Memory: the entries plus up to half as many unused ones after growth (growth by 1.5x
// keeps the inserts of a growing column amortized O(1)); a row emptied by Deintegrate
// returns its block to the pool. The row itself is 16 bytes (it is a y node's value).
//
// Thread safety: not thread safe; SkiMap serializes writers with readers per x column.
// The owner must call Clear(pool) before destroying a non-empty row.
#ifndef SKIMAP_Z_ROW_H_
#define SKIMAP_Z_ROW_H_

#include <algorithm>
#include <cassert>
#include <cstddef>
#include <cstdint>
#include <new>
#include <utility>

#include "skimap/node_pool.h"

namespace skimap {

// What a write did.
struct WriteStats {
  size_t voxels_touched = 0;  // distinct voxels updated, created or removed
  size_t voxels_created = 0;
  size_t voxels_removed = 0;
  void operator+=(const WriteStats& o) {
    voxels_touched += o.voxels_touched;
    voxels_created += o.voxels_created;
    voxels_removed += o.voxels_removed;
  }
};

template <class V>
class ZRow {
 public:
  struct Entry {
    int32_t key;
    V value;
  };

  ZRow() = default;
  ZRow(ZRow&& other) noexcept { *this = std::move(other); }
  ZRow& operator=(ZRow&& other) noexcept {
    std::swap(data_, other.data_);
    std::swap(size_, other.size_);
    std::swap(capacity_, other.capacity_);
    return *this;
  }
  ZRow(const ZRow&) = delete;
  ZRow& operator=(const ZRow&) = delete;
  // REQUIRES: Clear(pool) was called (or the row never held memory).
  ~ZRow() { assert(capacity_ == 0); }

  uint32_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  const Entry* begin() const { return data_; }
  const Entry* end() const { return data_ + size_; }
  // Starts loading the first entries into the cache.
  void PrefetchHead() const { __builtin_prefetch(data_); }

  // First entry with key >= z, or end().
  const Entry* LowerBound(int32_t z) const { return LowerBoundIn(data_, data_ + size_, z); }
  // The entries with lo <= key <= hi, as [first, last). One bound per end: a loop over
  // the range then has a single exit (compilers keep a caller's accumulator in a register
  // over such loops, not over a loop that also tests each key).
  std::pair<const Entry*, const Entry*> Range(int32_t lo, int32_t hi) const {
    const Entry* first = LowerBound(lo);
    const Entry* last = end();
    if (first != last && (last - 1)->key > hi) {
      last = hi == INT32_MAX ? last : LowerBoundIn(first, last, hi + 1);
    }
    return {first, last};
  }
  // The entry with key z, or nullptr.
  const Entry* Find(int32_t z) const {
    const Entry* e = LowerBound(z);
    return e != end() && e->key == z ? e : nullptr;
  }

  // value += item.data for the items [begin, end) (Item: .key.z and .data; ascending,
  // distinct z). A missing voxel is created unless its data is empty; a voxel left empty
  // is removed. Adds to *stats and to *heap_bytes (the change of V::HeapBytes).
  template <class Item>
  void Integrate(NodePool& pool, const Item* begin, const Item* end, WriteStats* stats,
                 size_t* heap_bytes) {
    Entry* at = data_;
    Entry* const last = data_ + size_;
    uint32_t missing = 0;
    bool emptied = false;
    for (const Item* it = begin; it != end; ++it) {
      ++stats->voxels_touched;
      at = LowerBoundIn(at, last, it->key.z);
      if (at != last && at->key == it->key.z) {
        const size_t before = at->value.HeapBytes();
        at->value += it->data;
        *heap_bytes += at->value.HeapBytes() - before;
        emptied |= at->value.IsEmpty();
        ++at;
      } else if (it->data.IsEmpty()) {
        // V() += empty stays empty: created and removed at once (as a node would be).
        ++stats->voxels_created;
        ++stats->voxels_removed;
      } else {
        ++missing;
      }
    }
    if (missing > 0) InsertMissing(pool, begin, end, missing, stats, heap_bytes);
    if (emptied) RemoveEmpty(pool, stats, heap_bytes);
  }

  // value -= item.data for the items whose voxel exists (same item contract); voxels left
  // empty are removed, and an emptied row frees its block.
  template <class Item>
  void Deintegrate(NodePool& pool, const Item* begin, const Item* end, WriteStats* stats,
                   size_t* heap_bytes) {
    Entry* at = data_;
    Entry* const last = data_ + size_;
    bool emptied = false;
    for (const Item* it = begin; it != end && at != last; ++it) {
      at = LowerBoundIn(at, last, it->key.z);
      if (at == last || at->key != it->key.z) continue;
      ++stats->voxels_touched;
      const size_t before = at->value.HeapBytes();
      at->value -= it->data;
      *heap_bytes += at->value.HeapBytes() - before;
      emptied |= at->value.IsEmpty();
      ++at;
    }
    if (emptied) RemoveEmpty(pool, stats, heap_bytes);
  }

  // Room for n entries in all (no effect when there is already).
  void Reserve(NodePool& pool, uint32_t n) {
    if (n > capacity_) Reallocate(pool, n);
  }
  // Appends (z, value). REQUIRES: z greater than every key of the row.
  void Append(NodePool& pool, int32_t z, V value) {
    assert(size_ == 0 || data_[size_ - 1].key < z);
    if (size_ == capacity_) Reallocate(pool, Grown(size_ + 1));
    new (&data_[size_]) Entry{z, std::move(value)};
    ++size_;
  }

  // Destroys every entry and returns the block to the pool.
  void Clear(NodePool& pool) {
    for (uint32_t i = 0; i < size_; ++i) data_[i].~Entry();
    if (capacity_ > 0) pool.Free(data_, Bytes(capacity_));
    data_ = nullptr;
    size_ = capacity_ = 0;
  }

  static constexpr size_t Bytes(uint32_t entries) { return size_t{entries} * sizeof(Entry); }
  // What a block of `entries` takes from a NodePool's chunks: its rounded size, or 0 when
  // it is too large for the pool and comes from the heap (for NodePool::Reserve).
  static constexpr size_t PooledBytes(uint32_t entries) {
    const size_t bytes = (Bytes(entries) + NodePool::kAlign - 1) & ~(NodePool::kAlign - 1);
    return bytes <= NodePool::kMaxPooledBytes ? bytes : 0;
  }

 private:
  // Binary search while the range is long, then a linear scan (rows are mostly short, and
  // a batch's items advance through a row in order).
  static Entry* LowerBoundIn(Entry* first, Entry* last, int32_t z) {
    size_t n = static_cast<size_t>(last - first);
    while (n > 8) {
      const size_t half = n / 2;
      if (first[half].key < z) {
        first += half + 1;
        n -= half + 1;
      } else {
        n = half;
      }
    }
    while (first != last && first->key < z) ++first;
    return first;
  }
  static const Entry* LowerBoundIn(const Entry* first, const Entry* last, int32_t z) {
    return LowerBoundIn(const_cast<Entry*>(first), const_cast<Entry*>(last), z);
  }

  uint32_t Grown(uint32_t needed) const { return std::max(needed, capacity_ + capacity_ / 2); }

  void Reallocate(NodePool& pool, uint32_t capacity) {
    assert(capacity >= size_);
    Entry* fresh = static_cast<Entry*>(pool.Allocate(Bytes(capacity)));
    for (uint32_t i = 0; i < size_; ++i) {
      new (&fresh[i]) Entry(std::move(data_[i]));
      data_[i].~Entry();
    }
    if (capacity_ > 0) pool.Free(data_, Bytes(capacity_));
    data_ = fresh;
    capacity_ = capacity;
  }

  // Inserts the `missing` items of [begin, end) that have no entry and non-empty data,
  // merging from the back so that each old entry moves once.
  template <class Item>
  void InsertMissing(NodePool& pool, const Item* begin, const Item* end, uint32_t missing,
                     WriteStats* stats, size_t* heap_bytes) {
    const uint32_t total = size_ + missing;
    if (total > capacity_) Reallocate(pool, Grown(total));
    int64_t old = static_cast<int64_t>(size_) - 1;  // last old entry not yet placed
    int64_t w = static_cast<int64_t>(total) - 1;    // next slot to fill
    for (const Item* it = end; it != begin && w > old;) {
      const Item& item = *(it - 1);
      if (old >= 0 && data_[old].key > item.key.z) {
        new (&data_[w]) Entry(std::move(data_[old]));
        data_[old].~Entry();
        --old;
        --w;
        continue;
      }
      --it;
      if ((old >= 0 && data_[old].key == item.key.z) || item.data.IsEmpty()) continue;
      new (&data_[w]) Entry{item.key.z, V()};
      data_[w].value += item.data;
      *heap_bytes += data_[w].value.HeapBytes();
      ++stats->voxels_created;
      --w;
    }
    size_ = total;
  }

  // Removes the entries whose value is empty, keeping the order; frees an emptied row.
  void RemoveEmpty(NodePool& pool, WriteStats* stats, size_t* heap_bytes) {
    uint32_t w = 0;
    for (uint32_t r = 0; r < size_; ++r) {
      if (data_[r].value.IsEmpty()) {
        *heap_bytes -= data_[r].value.HeapBytes();
        data_[r].~Entry();
        ++stats->voxels_removed;
        continue;
      }
      if (w != r) {
        new (&data_[w]) Entry(std::move(data_[r]));
        data_[r].~Entry();
      }
      ++w;
    }
    size_ = w;
    if (size_ == 0) Clear(pool);
  }

  Entry* data_ = nullptr;
  uint32_t size_ = 0;
  uint32_t capacity_ = 0;
};

}  // namespace skimap

#endif  // SKIMAP_Z_ROW_H_
