// YRow<V>: the y level of one x column of a SkiMap: its non-empty (x, y) rows as one sorted
// run of (y, ZRow) entries in memory from the column's NodePool.
//
//   YRow<RGBWeightedVoxel> ys;
//   ys.Integrate(pool, items, items + n, &stats, &heap_bytes);  // sorted by (y, z), distinct
//   for (const auto& e : ys) for (const auto& v : e.value) ...  // ascending y, then z
//   const auto* e = ys.Find(y);                                 // O(log n); its ZRow
//   ys.Clear(pool);                                             // before destruction
//
// Why a run and not a skip list: a batch touches a column's rows in y order, often rows
// next to each other. A skip list walks a finger node by node (a pointer chase and a
// branch per step, with nodes scattered over the pool); a run finds the next row by
// galloping forward from the last one in contiguous memory, and all the new rows of a
// batch go in with one merge from the back, each old entry moving once (twice when the
// block must grow first). Access stays
// O(log n) by binary search and the level stays ordered; a batch that adds rows to a
// column costs one pass over its entries (24 bytes each: a few microseconds for the
// longest columns of a room at 1 cm).
//
// Thread safety: not thread safe; SkiMap serializes writers with readers per x column.
// The owner must call Clear(pool) before destroying a non-empty YRow.
#ifndef SKIMAP_Y_ROW_H_
#define SKIMAP_Y_ROW_H_

#include <cstddef>
#include <cstdint>
#include <new>
#include <utility>

#include "skimap/keyed_run.h"
#include "skimap/node_pool.h"
#include "skimap/z_row.h"

namespace skimap {

template <class V>
class YRow : public KeyedRun<ZRow<V>> {
  using Base = KeyedRun<ZRow<V>>;
  using Base::data_;
  using Base::size_;

 public:
  using typename Base::Entry;

  // voxel += item.data for the items [begin, end) (Item: .key.y, .key.z and .data; sorted
  // by (y, z), distinct). Missing rows and voxels are created unless their data is empty;
  // voxels left empty are removed, and rows left empty too. Adds to *stats and *heap_bytes.
  template <class Item>
  void Integrate(NodePool& pool, const Item* begin, const Item* end, WriteStats* stats,
                 size_t* heap_bytes) {
    Entry* at = data_;
    Entry* const last = data_ + size_;
    uint32_t missing = 0;  // rows to create: absent, with some non-empty data
    size_t pooled = 0;     // what their z runs take from the pool
    bool emptied = false;
    for (const Item* it = begin; it != end;) {
      const Item* run_end = RunEnd(it, end);
      at = Base::GallopIn(at, last, it->key.y);
      if (at != last && at->key == it->key.y) {
        at->value.Integrate(pool, it, run_end, stats, heap_bytes);
        emptied |= at->value.empty();
        ++at;
      } else {
        const uint32_t n = NonEmpty(it, run_end);
        stats->voxels_touched += static_cast<size_t>(run_end - it);
        missing += n > 0;
        pooled += ZRow<V>::PooledBytes(n);
      }
      it = run_end;
    }
    if (missing > 0) {
      // A new column (every column of a first frame) gets its rows and runs from one chunk.
      if (size_ == 0) pool.Reserve(pooled + Base::PooledBytes(missing));
      InsertMissing(pool, begin, end, missing, stats, heap_bytes);
    }
    if (emptied) RemoveEmpty(pool);
  }

  // voxel -= item.data for the items whose voxel exists (same item contract); voxels left
  // empty are removed, rows left empty too.
  template <class Item>
  void Deintegrate(NodePool& pool, const Item* begin, const Item* end, WriteStats* stats,
                   size_t* heap_bytes) {
    Entry* at = data_;
    Entry* const last = data_ + size_;
    bool emptied = false;
    for (const Item* it = begin; it != end && at != last;) {
      const Item* run_end = RunEnd(it, end);
      at = Base::GallopIn(at, last, it->key.y);
      if (at != last && at->key == it->key.y) {
        at->value.Deintegrate(pool, it, run_end, stats, heap_bytes);
        emptied |= at->value.empty();
        ++at;
      }
      it = run_end;
    }
    if (emptied) RemoveEmpty(pool);
  }

  // Clears every row, then the run.
  void Clear(NodePool& pool) {
    for (uint32_t i = 0; i < size_; ++i) data_[i].value.Clear(pool);
    Base::Clear(pool);
  }

 private:
  template <class Item>
  static const Item* RunEnd(const Item* it, const Item* end) {
    const int32_t y = it->key.y;
    while (it != end && it->key.y == y) ++it;
    return it;
  }
  template <class Item>
  static uint32_t NonEmpty(const Item* it, const Item* end) {
    uint32_t n = 0;
    for (; it != end; ++it) n += !it->data.IsEmpty();
    return n;
  }

  // Inserts a row for each of the `missing` y runs of [begin, end) that has none and some
  // non-empty data, merging from the back so that each old entry moves once (twice when the
  // block grows first). A new row is built by appending its voxels (the run is sorted by
  // z), at its exact size.
  template <class Item>
  void InsertMissing(NodePool& pool, const Item* begin, const Item* end, uint32_t missing,
                     WriteStats* stats, size_t* heap_bytes) {
    const uint32_t total = size_ + missing;
    if (total > this->capacity_) this->Reallocate(pool, this->Grown(total));
    int64_t old = static_cast<int64_t>(size_) - 1;  // last old entry not yet placed
    int64_t w = static_cast<int64_t>(total) - 1;    // next slot to fill
    for (const Item* run_end = end; run_end != begin && w > old;) {
      const int32_t y = (run_end - 1)->key.y;
      if (old >= 0 && data_[old].key > y) {
        this->Relocate(static_cast<uint32_t>(old), static_cast<uint32_t>(w));
        --old;
        --w;
        continue;
      }
      const Item* run = run_end - 1;
      while (run != begin && (run - 1)->key.y == y) --run;
      const Item* const run_last = run_end;
      run_end = run;
      if (old >= 0 && data_[old].key == y) continue;  // merged in the first pass
      const uint32_t n = NonEmpty(run, run_last);
      if (n == 0) continue;
      Entry* e = new (&data_[w]) Entry{y, ZRow<V>()};
      e->value.Reserve(pool, n);
      for (; run != run_last; ++run) {
        if (run->data.IsEmpty()) continue;
        V v;
        v += run->data;
        *heap_bytes += v.HeapBytes();
        e->value.Append(pool, run->key.z, std::move(v));
        ++stats->voxels_created;
      }
      --w;
    }
    size_ = total;
  }

  // Removes the rows left empty (their blocks are already freed), keeping the order; an
  // emptied YRow frees its block.
  void RemoveEmpty(NodePool& pool) {
    uint32_t w = 0;
    for (uint32_t r = 0; r < size_; ++r) {
      if (data_[r].value.empty()) {
        data_[r].~Entry();
        continue;
      }
      if (w != r) this->Relocate(r, w);
      ++w;
    }
    size_ = w;
    if (size_ == 0) Base::Clear(pool);
  }
};

}  // namespace skimap

#endif  // SKIMAP_Y_ROW_H_
