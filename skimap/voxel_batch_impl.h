// Template definitions for voxel_batch.h: adding points and rows (over the pool's
// threads) and Finalize (radix sort by key, merge). Include voxel_batch.h, not this file.
#ifndef SKIMAP_VOXEL_BATCH_IMPL_H_
#define SKIMAP_VOXEL_BATCH_IMPL_H_

#include <algorithm>
#include <utility>
#include <vector>

namespace skimap {

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
    const size_t pieces = pool->pieces();
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
  // s.recent[h]: the index in out of the last item whose key hashes to h (kNoItem: none).
  // Indices are 32-bit: a range of 4 G points or more (no camera's) is only run-merged.
  s.recent.assign(kRecentSlots, kNoItem);
  const bool merge_rows = (end - begin) * cols < kNoItem;
  size_t n = 0;  // items in out[0..)
  size_t no_key = 0;
  for (size_t r = begin; r < end; ++r) {
    fill_row(r, KeyRow{s.x.data(), s.y.data(), s.z.data(), s.state.data()}, s.data.data());
    RunWriter runs{out + n};
    for (size_t c = 0; c < cols; ++c) {
      const uint8_t state = s.state[c];
      if (state != kUse) {
        no_key += state == kNoKey;
        continue;
      }
      runs.Add(VoxelKey{s.x[c], s.y[c], s.z[c]}, s.data[c]);
    }
    // The row's runs join an earlier item with the same key when the table remembers one
    // (most often the run above, in the previous row), and are kept in place otherwise.
    const size_t row_end = n + runs.Finish();
    if (!merge_rows) {
      n = row_end;
      continue;
    }
    for (size_t i = n; i < row_end; ++i) {
      const uint32_t h = RecentSlot(out[i].key);
      const uint32_t j = s.recent[h];
      if (j != kNoItem && SameKey(out[j].key, out[i].key)) {
        out[j].data += out[i].data;
        continue;
      }
      s.recent[h] = static_cast<uint32_t>(n);
      if (n != i) out[n] = std::move(out[i]);
      ++n;
    }
  }
  *rejected += no_key;
  return n;
}

template <Voxel V>
template <class RowFn>
void VoxelBatch<V>::AddRows(size_t rows, size_t cols, RowFn&& fill_row, ThreadPool* pool) {
  const size_t count = rows * cols;
  Reserve(n_ + count);
  Item* out = storage_.data() + n_;
  const bool parallel = pool != nullptr && pool->workers() > 0 && count >= kParallelMinPoints;
  const size_t pieces = parallel ? pool->pieces() : 1;
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
  const size_t parts = pool->pieces();
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

#endif  // SKIMAP_VOXEL_BATCH_IMPL_H_
