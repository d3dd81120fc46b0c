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
// Storage, search and memory are KeyedRun's (keyed_run.h); a row emptied by Deintegrate
// returns its block to the pool. The row itself is 16 bytes (it is a y entry's value).
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

#include "skimap/keyed_run.h"
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
class ZRow : public KeyedRun<V> {
  using Base = KeyedRun<V>;
  using Base::capacity_;
  using Base::data_;
  using Base::size_;

 public:
  using typename Base::Entry;

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
      at = Base::LowerBoundIn(at, last, it->key.z);
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
      at = Base::LowerBoundIn(at, last, it->key.z);
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

 private:
  // Inserts the `missing` items of [begin, end) that have no entry and non-empty data,
  // merging from the back so that each old entry moves once (twice when the block grows
  // first).
  template <class Item>
  void InsertMissing(NodePool& pool, const Item* begin, const Item* end, uint32_t missing,
                     WriteStats* stats, size_t* heap_bytes) {
    const uint32_t total = size_ + missing;
    if (total > capacity_) this->Reallocate(pool, this->Grown(total));
    int64_t old = static_cast<int64_t>(size_) - 1;  // last old entry not yet placed
    int64_t w = static_cast<int64_t>(total) - 1;    // next slot to fill
    for (const Item* it = end; it != begin && w > old;) {
      const Item& item = *(it - 1);
      if (old >= 0 && data_[old].key > item.key.z) {
        this->Relocate(static_cast<uint32_t>(old), static_cast<uint32_t>(w));
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
      if (w != r) this->Relocate(r, w);
      ++w;
    }
    size_ = w;
    if (size_ == 0) this->Clear(pool);
  }
};

}  // namespace skimap

#endif  // SKIMAP_Z_ROW_H_
