// Template definitions for skimap.h. Include skimap.h, not this file.
#ifndef SKIMAP_SKIMAP_IMPL_H_
#define SKIMAP_SKIMAP_IMPL_H_

#include <algorithm>
#include <atomic>
#include <utility>

namespace skimap {

namespace internal {
// Seed of the RNG of column x: distinct per column, reproducible for a given map seed.
inline uint32_t MixSeed(uint32_t seed, int32_t x, int32_t y) {
  uint64_t h = (uint64_t{static_cast<uint32_t>(x)} << 32) ^ static_cast<uint32_t>(y) ^ seed;
  h ^= h >> 33;
  h *= 0xff51afd7ed558ccdull;
  h ^= h >> 33;
  const uint32_t r = static_cast<uint32_t>(h);
  return r == 0 ? 1 : r;
}
// A write number no column of any map has had: versions stay unique across maps, and
// across a column removed and created again.
inline uint64_t NextColumnVersion() {
  static std::atomic<uint64_t> writes{0};
  return writes.fetch_add(1, std::memory_order_relaxed) + 1;
}
// Below this many voxels a batch is applied on the calling thread alone.
inline constexpr size_t kParallelMinItems = 4096;
}  // namespace internal

template <Voxel V>
struct SkiMap<V>::Column {
  using YList = SkipListCore<int32_t, ZList>;
  explicit Column(const SkipListOptions& options) : arena(options) {}
  ~Column() ABSL_NO_THREAD_SAFETY_ANALYSIS {
    for (auto* n = ys.First(); n != nullptr; n = n->next[0]) n->value.Clear(arena);
    ys.Clear(arena);
  }
  mutable RwLock mu;
  // The process-wide write number of the last write to this column, and of the last write
  // to each of its y blocks (y >> kYBlockShift; sorted by block): ForEachColumnVersion.
  std::atomic<uint64_t> version{0};
  std::vector<std::pair<int32_t, uint64_t>> y_blocks ABSL_GUARDED_BY(mu);
  SkipListArena arena ABSL_GUARDED_BY(mu);
  YList ys ABSL_GUARDED_BY(mu);
  size_t heap_bytes ABSL_GUARDED_BY(mu) = 0;  // sum of V::HeapBytes in this column
};

template <Voxel V>
struct SkiMap<V>::Run {
  int32_t x;
  size_t begin, end;
  Column* column;
  WriteStats stats;
};

template <Voxel V>
SkiMap<V>::SkiMap(const Options& options)
    : options_(options), grid_(options.resolution, options.origin), xs_(options.lists) {}

template <Voxel V>
SkiMap<V>::~SkiMap() = default;

template <Voxel V>
absl::Status SkiMap<V>::Integrate(const Point3& p, const V& data) {
  VoxelKey key;
  if (!grid_.ToKey(p, &key)) {
    return absl::InvalidArgumentError("point: outside the map's key range or not finite");
  }
  IntegrateKey(key, data);
  return absl::OkStatus();
}

template <Voxel V>
absl::Status SkiMap<V>::Deintegrate(const Point3& p, const V& data) {
  VoxelKey key;
  if (!grid_.ToKey(p, &key)) {
    return absl::InvalidArgumentError("point: outside the map's key range or not finite");
  }
  DeintegrateKey(key, data);
  return absl::OkStatus();
}

template <Voxel V>
WriteStats SkiMap<V>::IntegrateKey(const VoxelKey& key, const V& data) {
  const typename VoxelBatch<V>::Item item{key, data};
  WriterLock lock(&writer_mu_);
  return Apply(&item, 1, /*integrate=*/true);
}

template <Voxel V>
WriteStats SkiMap<V>::DeintegrateKey(const VoxelKey& key, const V& data) {
  const typename VoxelBatch<V>::Item item{key, data};
  WriterLock lock(&writer_mu_);
  return Apply(&item, 1, /*integrate=*/false);
}

template <Voxel V>
WriteStats SkiMap<V>::Integrate(const VoxelBatch<V>& batch) {
  assert(batch.finalized());
  WriterLock lock(&writer_mu_);
  return Apply(batch.items().data(), batch.size(), /*integrate=*/true);
}

template <Voxel V>
WriteStats SkiMap<V>::Deintegrate(const VoxelBatch<V>& batch) {
  assert(batch.finalized());
  WriterLock lock(&writer_mu_);
  return Apply(batch.items().data(), batch.size(), /*integrate=*/false);
}

template <Voxel V>
bool SkiMap<V>::Erase(const VoxelKey& key) {
  WriterLock lock(&writer_mu_);
  std::optional<V> current = Find(key);
  if (!current) return false;
  const typename VoxelBatch<V>::Item item{key, *current};
  // Subtracting a voxel from itself empties it, for every voxel type.
  Apply(&item, 1, /*integrate=*/false);
  return true;
}

template <Voxel V>
void SkiMap<V>::Clear() {
  WriterLock lock(&writer_mu_);
  WriterLock x_lock(&x_mu_);
  xs_.Clear();
  size_.store(0, std::memory_order_relaxed);
}

template <Voxel V>
void SkiMap<V>::Compact() {
  WriterLock lock(&writer_mu_);
  std::vector<std::pair<int32_t, Column*>> columns;
  {
    ReaderLock x_lock(&x_mu_);
    for (auto* xn = xs_.First(); xn != nullptr; xn = xn->next[0]) {
      columns.emplace_back(xn->key, xn->value.get());
    }
  }
  for (auto [x, old] : columns) {
    std::unique_ptr<Column> fresh = CopyColumn(*old, ColumnOptions(x));
    WriterLock x_lock(&x_mu_);  // no reader is inside any column while we hold this
    std::swap(*xs_.Find(x), fresh);
  }  // `fresh` now holds the old column: destroyed here, outside the lock
}

template <Voxel V>
SkipListOptions SkiMap<V>::ColumnOptions(int32_t x) const {
  SkipListOptions lists = options_.lists;
  lists.seed = internal::MixSeed(lists.seed, x, INT32_MIN);
  return lists;
}

template <Voxel V>
std::unique_ptr<typename SkiMap<V>::Column> SkiMap<V>::CopyColumn(
    const Column& old, const SkipListOptions& options) ABSL_NO_THREAD_SAFETY_ANALYSIS {
  // `fresh` is not shared yet: no lock needed on it.
  auto fresh = std::make_unique<Column>(options);
  ReaderLock lock(&old.mu);
  fresh->arena.pool().Reserve(old.arena.pool().BytesInUse() + old.arena.pool().BytesInUse() / 8);
  typename Column::YList::Finger yf;
  for (auto* yn = old.ys.First(); yn != nullptr; yn = yn->next[0]) {
    bool inserted = false;
    auto* y = fresh->ys.FindOrInsert(fresh->arena, yf, yn->key, &inserted);
    typename ZList::Finger zf;
    for (const ZNode* zn = yn->value.First(); zn != nullptr; zn = zn->next[0]) {
      y->value.FindOrInsert(fresh->arena, zf, zn->key, &inserted)->value = zn->value;
    }
  }
  fresh->heap_bytes = old.heap_bytes;
  fresh->version.store(old.version.load(std::memory_order_acquire), std::memory_order_release);
  fresh->y_blocks = old.y_blocks;
  return fresh;
}

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
      auto column = std::make_unique<Column>(ColumnOptions(r.x));
      r.column = column.get();
      xs_.Insert(r.x, std::move(column));
    }
  }

  const uint64_t version = internal::NextColumnVersion();
  auto apply_runs = [&](size_t first, size_t last) {
    for (size_t i = first; i < last; ++i) {
      Run& r = runs[i];
      if (r.column == nullptr) continue;
      WriterLock lock(&r.column->mu);
      r.stats = ApplyToColumn(*r.column, r.x, items + r.begin, items + r.end, integrate);
      r.column->version.store(version, std::memory_order_release);
      StampYBlocks(*r.column, items + r.begin, items + r.end, version);
    }
  };
  ThreadPool* pool = options_.pool;
  if (pool != nullptr && pool->workers() > 0 && n >= internal::kParallelMinItems &&
      runs.size() > 1) {
    // Pieces of about equal item counts: piece p takes the runs starting in its share.
    const size_t pieces = static_cast<size_t>(pool->workers()) + 1;
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

template <Voxel V>
WriteStats SkiMap<V>::ApplyToColumn(Column& c, int32_t x, const typename VoxelBatch<V>::Item* begin,
                                    const typename VoxelBatch<V>::Item* end, bool integrate)
    ABSL_NO_THREAD_SAFETY_ANALYSIS {  // caller holds c.mu
  using YList = typename Column::YList;
  WriteStats s;
  typename YList::Finger yf;
  // A new column (every column of a first frame) is built by appending: the batch is sorted,
  // so no search is needed, and its nodes come from one chunk reserved up front.
  const bool new_column = integrate && c.ys.empty();
  if (new_column) {
    size_t ys = 0;
    for (auto* it = begin; it != end; ++it) ys += it == begin || it->key.y != it[-1].key.y;
    // Nodes of height 1, plus the towers of the taller ones (1/3 pointer per node at p=1/4).
    const size_t per_node = sizeof(void*) / 2;
    c.arena.pool().Reserve(static_cast<size_t>(end - begin) * (ZList::NodeBytes(1) + per_node) +
                           ys * (YList::NodeBytes(1) + per_node));
  }
  for (auto* it = begin; it != end;) {
    const int32_t y = it->key.y;
    auto* run_end = it;
    while (run_end != end && run_end->key.y == y) ++run_end;
    typename YList::Node* yn;
    bool fresh = false;  // yn is a new entry: its voxels are appended without search
    if (new_column) {
      // Empty data makes no voxel (V() += empty stays empty), so no entry for a run of it.
      for (; it != run_end && it->data.IsEmpty(); ++it) ++s.voxels_touched;
      if (it == run_end) continue;
      yn = c.ys.Append(c.arena, yf, y);
      fresh = true;
    } else if (integrate) {
      yn = c.ys.FindOrInsert(c.arena, yf, y, &fresh);
    } else {
      yn = c.ys.Seek(yf, y);
      if (yn == nullptr || yn->key != y) {
        it = run_end;
        continue;
      }
    }
    if (fresh) {
      typename ZList::Finger append;
      for (; it != run_end; ++it) {
        ++s.voxels_touched;
        if (it->data.IsEmpty()) continue;
        ZNode* zn = yn->value.Append(c.arena, append, it->key.z);
        zn->value += it->data;
        c.heap_bytes += zn->value.HeapBytes();
        ++s.voxels_created;
      }
      // Only FindOrInsert's entries can end empty (a new column's start with real data),
      // and yf is then a Seek finger, as Erase needs.
      if (yn->value.empty()) c.ys.Erase(c.arena, yf, y);
      continue;
    }
    ZList& zl = yn->value;
    typename ZList::Finger zf;
    for (; it != run_end; ++it) {
      const int32_t z = it->key.z;
      ZNode* zn;
      bool created = false;
      if (integrate) {
        zn = zl.FindOrInsert(c.arena, zf, z, &created);
      } else {
        zn = zl.Seek(zf, z);
        if (zn == nullptr || zn->key != z) continue;
      }
      const size_t heap_before = zn->value.HeapBytes();
      if (integrate) {
        zn->value += it->data;
      } else {
        zn->value -= it->data;
      }
      ++s.voxels_touched;
      s.voxels_created += created;
      if (zn->value.IsEmpty()) {
        c.heap_bytes -= heap_before;
        zl.Erase(c.arena, zf, z);
        ++s.voxels_removed;
      } else {
        c.heap_bytes += zn->value.HeapBytes() - heap_before;
      }
    }
    if (zl.empty()) c.ys.Erase(c.arena, yf, y);
  }
  return s;
}

template <Voxel V>
std::optional<V> SkiMap<V>::Find(const VoxelKey& key) const {
  ReaderLock x_lock(&x_mu_);
  const std::unique_ptr<Column>* c = xs_.Find(key.x);
  if (c == nullptr) return std::nullopt;
  const Column& column = **c;
  ReaderLock lock(&column.mu);
  const auto* yn = column.ys.Find(key.y);
  if (yn == nullptr) return std::nullopt;
  const ZNode* zn = yn->value.Find(key.z);
  if (zn == nullptr) return std::nullopt;
  return zn->value;
}

template <Voxel V>
std::optional<KeyBox> SkiMap<V>::Bounds() const {
  ReaderLock x_lock(&x_mu_);
  if (xs_.empty()) return std::nullopt;
  KeyBox b{{kMaxKey, kMaxKey, kMaxKey}, {kMinKey, kMinKey, kMinKey}};
  b.min.x = xs_.First()->key;
  b.max.x = xs_.Last()->key;
  for (auto* xn = xs_.First(); xn != nullptr; xn = xn->next[0]) {
    const Column& column = *xn->value;
    ReaderLock lock(&column.mu);
    b.min.y = std::min(b.min.y, column.ys.First()->key);
    b.max.y = std::max(b.max.y, column.ys.Last()->key);
    for (auto* yn = column.ys.First(); yn != nullptr; yn = yn->next[0]) {
      b.min.z = std::min(b.min.z, yn->value.First()->key);
      b.max.z = std::max(b.max.z, yn->value.Last()->key);
    }
  }
  return b;
}

template <Voxel V>
std::optional<KeyBox> SkiMap<V>::FootprintBounds() const {
  ReaderLock x_lock(&x_mu_);
  if (xs_.empty()) return std::nullopt;
  KeyBox b;
  b.min.x = xs_.First()->key;
  b.max.x = xs_.Last()->key;
  b.min.y = kMaxKey;
  b.max.y = kMinKey;
  for (auto* xn = xs_.First(); xn != nullptr; xn = xn->next[0]) {
    const Column& column = *xn->value;
    ReaderLock lock(&column.mu);
    b.min.y = std::min(b.min.y, column.ys.First()->key);
    b.max.y = std::max(b.max.y, column.ys.Last()->key);
  }
  return b;
}

template <Voxel V>
size_t SkiMap<V>::MemoryUsage() const {
  ReaderLock x_lock(&x_mu_);
  size_t bytes = sizeof(*this) - sizeof(xs_) + xs_.MemoryUsage();
  for (auto* xn = xs_.First(); xn != nullptr; xn = xn->next[0]) {
    const Column& column = *xn->value;
    ReaderLock lock(&column.mu);
    bytes += sizeof(Column) + column.arena.pool().BytesReserved() + column.heap_bytes;
  }
  return bytes;
}

}  // namespace skimap

#include "skimap/skimap_search_impl.h"  // IWYU pragma: export

#endif  // SKIMAP_SKIMAP_IMPL_H_
