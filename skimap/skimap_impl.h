// Template definitions for skimap.h. Include skimap.h, not this file.
#ifndef SKIMAP_SKIMAP_IMPL_H_
#define SKIMAP_SKIMAP_IMPL_H_

#include <algorithm>
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

  auto apply_runs = [&](size_t first, size_t last) {
    for (size_t i = first; i < last; ++i) {
      Run& r = runs[i];
      if (r.column == nullptr) continue;
      WriterLock lock(&r.column->mu);
      r.stats = ApplyToColumn(*r.column, r.x, items + r.begin, items + r.end, integrate);
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
  // Appends the run [it, run_end) to the empty z list of y node `yn` (made on first need
  // by make_yn when null); items with empty data are skipped, as V() += empty stays empty.
  auto append_run = [&](const typename VoxelBatch<V>::Item*& it,
                        const typename VoxelBatch<V>::Item* run_end, typename YList::Node* yn,
                        auto make_yn) {
    typename ZList::Finger zf;
    for (; it != run_end; ++it) {
      ++s.voxels_touched;
      if (it->data.IsEmpty()) continue;
      if (yn == nullptr) yn = make_yn();
      ZNode* zn = yn->value.Append(c.arena, zf, it->key.z);
      zn->value += it->data;
      c.heap_bytes += zn->value.HeapBytes();
      ++s.voxels_created;
    }
    return yn;
  };
  for (auto* it = begin; it != end;) {
    const int32_t y = it->key.y;
    auto* run_end = it;
    while (run_end != end && run_end->key.y == y) ++run_end;
    if (new_column) {
      append_run(it, run_end, nullptr, [&] { return c.ys.Append(c.arena, yf, y); });
      continue;
    }
    typename YList::Node* yn;
    if (integrate) {
      bool inserted = false;  // a new y entry starts with an empty z list
      yn = c.ys.FindOrInsert(c.arena, yf, y, &inserted);
      if (inserted) {
        append_run(it, run_end, yn, [] { return nullptr; });
        if (yn->value.empty()) c.ys.Erase(c.arena, yf, y);
        continue;
      }
    } else {
      yn = c.ys.Seek(yf, y);
      if (yn == nullptr || yn->key != y) {
        it = run_end;
        continue;
      }
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
template <class Fn>
void SkiMap<V>::ForEachInBox(const KeyBox& box, Fn&& fn) const {
  if (box.empty()) return;
  // Boxes a few hundred voxels wide: many short searches, best interleaved. Wider ones are
  // long sequential walks, where buffering a group's rows would only cost cache.
  constexpr int64_t kMaxInterleavedSpan = 1024;
  if (int64_t{box.max.y} - box.min.y >= kMaxInterleavedSpan) {
    WalkBox(box, fn);
    return;
  }
  struct None {};
  SearchColumns<None, None>(
      box.min.x, box.max.x,
      [&](int32_t, None*, int32_t* y0, int32_t* y1) {
        *y0 = box.min.y, *y1 = box.max.y;
        return true;
      },
      [&](const None&, int32_t, None*, int32_t* z0, int32_t* z1) {
        *z0 = box.min.z, *z1 = box.max.z;
        return true;
      },
      [](const None&, int32_t) { return true; }, fn);
}

template <Voxel V>
template <class Fn>
void SkiMap<V>::WalkBox(const KeyBox& box, Fn&& fn) const {
  ReaderLock x_lock(&x_mu_);
  for (auto* xn = xs_.LowerBound(box.min.x); xn != nullptr && xn->key <= box.max.x;
       xn = xn->next[0]) {
    const Column& column = *xn->value;
    ReaderLock lock(&column.mu);
    for (auto* yn = column.ys.LowerBound(box.min.y); yn != nullptr && yn->key <= box.max.y;
         yn = yn->next[0]) {
      for (const ZNode* zn = yn->value.LowerBound(box.min.z); zn != nullptr && zn->key <= box.max.z;
           zn = zn->next[0]) {
        fn(VoxelKey{xn->key, yn->key, zn->key}, zn->value);
      }
    }
  }
}

template <Voxel V>
template <class Fn>
void SkiMap<V>::RadiusSearch(const Point3& c, double radius, Fn&& fn) const {
  if (!(radius >= 0) || !std::isfinite(radius)) return;
  const double r2 = radius * radius;
  const Point3& o = grid_.origin();
  int32_t x0, x1;
  grid_.CenterRange(c.x - radius, c.x + radius, o.x, &x0, &x1);
  if (x0 > x1) return;
  // Column state: r² - dx²; row state: r² - dx² - dy².
  SearchColumns<double, double>(
      x0, x1,
      [&](int32_t x, double* rem_x, int32_t* y0, int32_t* y1) {
        const double dx = grid_.AxisCenter(x, o.x) - c.x;
        *rem_x = r2 - dx * dx;
        if (*rem_x < 0) return false;
        const double sy = std::sqrt(*rem_x);
        grid_.CenterRange(c.y - sy, c.y + sy, o.y, y0, y1);
        return *y0 <= *y1;
      },
      [&](double rem_x, int32_t y, double* rem_xy, int32_t* z0, int32_t* z1) {
        const double dy = grid_.AxisCenter(y, o.y) - c.y;
        *rem_xy = rem_x - dy * dy;
        if (*rem_xy < 0) return false;
        const double sz = std::sqrt(*rem_xy);
        grid_.CenterRange(c.z - sz, c.z + sz, o.z, z0, z1);
        return *z0 <= *z1;
      },
      [&](double rem_xy, int32_t z) {
        const double dz = grid_.AxisCenter(z, o.z) - c.z;
        return dz * dz <= rem_xy;
      },
      fn);
}

template <Voxel V>
template <class ColState, class RowState, class ColFn, class RowFn, class KeepFn, class Fn>
void SkiMap<V>::SearchColumns(int32_t x0, int32_t x1, ColFn&& col_range, RowFn&& row_range,
                              KeepFn&& keep, Fn&& fn) const {
  // Columns are searched kGroup at a time, in three interleaved passes whose cache misses
  // overlap (a map's columns are far apart in memory): the y-list descents of the group
  // (LowerBoundMany); the walks over each column's y range, a node of each column in turn;
  // the z-list descents of every (x, y) row the group keeps. The rows are then scanned in
  // (x, y, z) order.
  constexpr size_t kGroup = 32;
  using YList = typename Column::YList;
  using YNode = typename YList::Node;
  struct Col {
    typename YList::Search search;  // first y >= y0
    int32_t x, y1;
    ColState state;
    size_t rows_begin, rows_end;
  };
  struct Row {
    typename ZList::Search search;  // first z >= z0
    int32_t y, z1;
    RowState state;
  };
  Col cols[kGroup];
  std::vector<Row> rows;
  auto run_group = [&](size_t n) {
    auto col_search = [](Col& col) -> typename YList::Search& { return col.search; };
    YList::LowerBoundMany(cols, n, col_search);
    // Each column's rows land in its own slice of `rows`, in y order.
    size_t capacity = 0;
    const YNode* at[kGroup];
    size_t walking[kGroup];
    size_t width = 0;
    for (size_t i = 0; i < n; ++i) {
      Col& col = cols[i];
      col.rows_begin = col.rows_end = capacity;
      const int64_t span = int64_t{col.y1} - col.search.key + 1;
      capacity += std::min<size_t>(static_cast<size_t>(span), col.search.list->size());
      at[i] = col.search.result;
      walking[width++] = i;
    }
    if (rows.size() < capacity) rows.resize(capacity);
    while (width > 0) {
      for (size_t j = 0; j < width;) {
        Col& col = cols[walking[j]];
        const YNode* yn = at[walking[j]];
        if (yn == nullptr || yn->key > col.y1) {
          walking[j] = walking[--width];
          continue;
        }
        at[walking[j]] = yn->next[0];
        __builtin_prefetch(yn->next[0]);
        ++j;
        Row row;
        int32_t z0;
        if (!row_range(std::as_const(col.state), yn->key, &row.state, &z0, &row.z1)) continue;
        yn->value.PrefetchHead();
        row.search = {&yn->value, z0, nullptr};
        row.y = yn->key;
        rows[col.rows_end++] = row;
      }
    }
    // Close the gaps between the slices, then scan every row of the group.
    size_t nrows = 0;
    for (size_t i = 0; i < n; ++i) {
      Col& col = cols[i];
      if (col.rows_begin != nrows) {
        std::copy(rows.begin() + col.rows_begin, rows.begin() + col.rows_end, rows.begin() + nrows);
      }
      col.rows_end = nrows + (col.rows_end - col.rows_begin);
      col.rows_begin = nrows;
      nrows = col.rows_end;
    }
    auto row_search = [](Row& row) -> typename ZList::Search& { return row.search; };
    ZList::LowerBoundMany(rows.data(), nrows, row_search);
    constexpr size_t kAhead = 4;  // rows whose second node is prefetched ahead of the scan
    for (size_t r = 0; r < std::min(kAhead, nrows); ++r) {
      if (rows[r].search.result != nullptr) __builtin_prefetch(rows[r].search.result->next[0]);
    }
    for (size_t i = 0; i < n; ++i) {
      for (size_t r = cols[i].rows_begin; r < cols[i].rows_end; ++r) {
        if (r + kAhead < nrows && rows[r + kAhead].search.result != nullptr) {
          __builtin_prefetch(rows[r + kAhead].search.result->next[0]);
        }
        const Row& row = rows[r];
        for (const ZNode* zn = row.search.result; zn != nullptr && zn->key <= row.z1;
             zn = zn->next[0]) {
          if (keep(row.state, zn->key)) fn(VoxelKey{cols[i].x, row.y, zn->key}, zn->value);
        }
      }
    }
  };
  ReaderLock x_lock(&x_mu_);
  // The group's shared column locks; released by flush() or, should `fn` throw, here.
  struct GroupLocks {
    const Column* columns[kGroup];
    size_t n = 0;
    void Release() ABSL_NO_THREAD_SAFETY_ANALYSIS {
      for (; n > 0; --n) columns[n - 1]->mu.ReaderUnlock();
    }
    ~GroupLocks() { Release(); }
  } locks;
  size_t n = 0;
  auto flush = [&] {
    run_group(n);
    locks.Release();
    n = 0;
  };
  for (auto* xn = xs_.LowerBound(x0); xn != nullptr && xn->key <= x1; xn = xn->next[0]) {
    Col& col = cols[n];
    int32_t y0;
    if (!col_range(xn->key, &col.state, &y0, &col.y1)) continue;
    const Column& column = *xn->value;
    // Shared locks of a group are taken in ascending x; writers never hold a column lock
    // while waiting for another, so holding several cannot deadlock.
    column.mu.ReaderLock();
    locks.columns[locks.n++] = &column;
    col.search = {&column.ys, y0, nullptr};
    col.x = xn->key;
    if (++n == kGroup) flush();
  }
  if (n > 0) flush();
}

template <Voxel V>
template <class Fn>
void SkiMap<V>::ForEachColumn(int32_t min_x, int32_t max_x, int32_t min_y, int32_t max_y,
                              Fn&& fn) const {
  ReaderLock x_lock(&x_mu_);
  for (auto* xn = xs_.LowerBound(min_x); xn != nullptr && xn->key <= max_x; xn = xn->next[0]) {
    const Column& column = *xn->value;
    ReaderLock lock(&column.mu);
    for (auto* yn = column.ys.LowerBound(min_y); yn != nullptr && yn->key <= max_y;
         yn = yn->next[0]) {
      fn(xn->key, yn->key, ZColumn(yn->value));
    }
  }
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

#endif  // SKIMAP_SKIMAP_IMPL_H_
