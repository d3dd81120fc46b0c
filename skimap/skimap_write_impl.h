// Template definitions for skimap.h: the write path of a batch (Apply: the batch split by
// x column, over the pool's threads; each column's y and z runs updated in one pass over
// its sorted keys, YRow::Integrate). Include skimap.h, not this file.
#ifndef SKIMAP_SKIMAP_WRITE_IMPL_H_
#define SKIMAP_SKIMAP_WRITE_IMPL_H_

#include <algorithm>
#include <atomic>
#include <utility>

namespace skimap {

template <Voxel V>
WriteStats SkiMap<V>::Apply(const typename VoxelBatch<V>::Item* items, size_t n, bool integrate) {
  std::vector<Run> runs;
  for (size_t i = 0; i < n;) {
    size_t j = i + 1;
    while (j < n && items[j].key.x == items[i].key.x) ++j;
    runs.push_back({items[i].key.x, i, j, nullptr, {}});
    i = j;
  }
  bool missing = false;
  {
    ReaderLock lock(&x_mu_);
    for (Run& r : runs) {
      const std::unique_ptr<Column>* c = xs_.Find(r.x);
      r.column = c != nullptr ? c->get() : nullptr;
      missing |= r.column == nullptr;
    }
  }
  if (integrate && missing) {
    WriterLock lock(&x_mu_);
    for (Run& r : runs) {
      if (r.column != nullptr) continue;
      auto column = std::make_unique<Column>();
      r.column = column.get();
      xs_.Insert(r.x, std::move(column));
    }
  }

  const uint64_t version = internal::NextColumnVersion();
  auto apply_runs = [&](size_t first, size_t last) {
    for (size_t i = first; i < last; ++i) {
      Run& r = runs[i];
      if (r.column == nullptr) continue;
      Column& c = *r.column;
      WriterLock lock(&c.mu);
      if (integrate) {
        c.ys.Integrate(c.pool, items + r.begin, items + r.end, &r.stats, &c.heap_bytes);
      } else {
        c.ys.Deintegrate(c.pool, items + r.begin, items + r.end, &r.stats, &c.heap_bytes);
      }
      c.version.store(version, std::memory_order_release);
      StampYBlocks(c, items + r.begin, items + r.end, version);
    }
  };
  ThreadPool* pool = options_.pool;
  if (pool != nullptr && pool->workers() > 0 && n >= internal::kParallelMinItems &&
      runs.size() > 1) {
    // Pieces of about equal item counts: piece p takes the runs starting in its share.
    const size_t pieces = pool->pieces();
    std::vector<size_t> piece_start(pieces + 1, runs.size());
    for (size_t p = 0, r = 0; p < pieces; ++p) {
      while (r < runs.size() && runs[r].begin < p * n / pieces) ++r;
      piece_start[p] = r;
    }
    pool->ParallelFor(pieces, [&](size_t first, size_t last) {
      for (size_t p = first; p < last; ++p) apply_runs(piece_start[p], piece_start[p + 1]);
    });
  } else {
    apply_runs(0, runs.size());
  }

  WriteStats total;
  std::vector<int32_t> emptied;
  for (const Run& r : runs) {
    total += r.stats;
    // A column may be empty after removals, or when it is new and all its data was empty.
    if (r.column == nullptr || (r.stats.voxels_removed == 0 && r.stats.voxels_created > 0))
      continue;
    ReaderLock lock(&r.column->mu);
    if (r.column->ys.empty()) emptied.push_back(r.x);
  }
  if (!emptied.empty()) {
    WriterLock lock(&x_mu_);
    for (int32_t x : emptied) xs_.Erase(x);
  }
  size_.fetch_add(total.voxels_created - total.voxels_removed, std::memory_order_relaxed);
  return total;
}

template <Voxel V>
void SkiMap<V>::StampYBlocks(Column& c, const typename VoxelBatch<V>::Item* begin,
                             const typename VoxelBatch<V>::Item* end, uint64_t version)
    ABSL_NO_THREAD_SAFETY_ANALYSIS {  // caller holds c.mu
  auto& blocks = c.y_blocks;
  int32_t last = 0;
  bool any = false;
  for (auto* it = begin; it != end; ++it) {
    const int32_t block = it->key.y >> kYBlockShift;
    if (any && block == last) continue;  // items are sorted by y: blocks come in runs
    any = true;
    last = block;
    auto pos = std::lower_bound(
        blocks.begin(), blocks.end(), block,
        [](const std::pair<int32_t, uint64_t>& b, int32_t key) { return b.first < key; });
    if (pos != blocks.end() && pos->first == block) {
      pos->second = version;
    } else {
      blocks.insert(pos, {block, version});
    }
  }
}

}  // namespace skimap

#endif  // SKIMAP_SKIMAP_WRITE_IMPL_H_
