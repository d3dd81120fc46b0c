// Template definitions of SkiMap's searches (ForEachInBox, RadiusSearch, ForEachColumn and
// the interleaved SearchColumns behind the first two). Include skimap.h, not this file.
#ifndef SKIMAP_SKIMAP_SEARCH_IMPL_H_
#define SKIMAP_SKIMAP_SEARCH_IMPL_H_

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

namespace skimap {

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
      const ZList& row = yn->value;
      const auto [first, last] = row.Range(box.min.z, box.max.z);
      for (auto* e = first; e != last; ++e) {
        fn(VoxelKey{xn->key, yn->key, e->key}, e->value);
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
  // Columns are searched kGroup at a time, in two interleaved passes whose cache misses
  // overlap (a map's columns are far apart in memory): the y-list descents of the group
  // (LowerBoundMany); the walks over each column's y range, a node of each column in turn,
  // prefetching the z run of every (x, y) row the group keeps. The rows are then scanned in
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
    const ZList* list;
    int32_t y, z0, z1;
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
        row.list = &yn->value;
        row.z0 = z0;
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
    // Each row's run was prefetched when its y node was read; rows are scanned in order.
    for (size_t i = 0; i < n; ++i) {
      for (size_t r = cols[i].rows_begin; r < cols[i].rows_end; ++r) {
        const Row& row = rows[r];
        const ZList& list = *row.list;
        const auto [first, last] = list.Range(row.z0, row.z1);
        for (auto* e = first; e != last; ++e) {
          if (keep(row.state, e->key)) fn(VoxelKey{cols[i].x, row.y, e->key}, e->value);
        }
      }
    }
  };
  ReaderLock x_lock(&x_mu_);
  // The group's shared column locks; released by flush() or, should `fn` throw, here.
  struct GroupLocks {
    const Column* columns[kGroup];
    size_t n = 0;
    // Lock counts vary at run time, which the analysis cannot follow: these two are the
    // only places that take and release the group's locks.
    void Add(const Column* column) ABSL_NO_THREAD_SAFETY_ANALYSIS {
      column->mu.ReaderLock();
      columns[n++] = column;
    }
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
    locks.Add(&column);
    col.search = {&column.ys, y0, nullptr};
    col.x = xn->key;
    if (++n == kGroup) flush();
  }
  if (n > 0) flush();
}

template <Voxel V>
template <class Fn>
void SkiMap<V>::ForEachColumnVersion(int32_t min_x, int32_t max_x, Fn&& fn) const {
  ReaderLock x_lock(&x_mu_);
  for (auto* xn = xs_.LowerBound(min_x); xn != nullptr && xn->key <= max_x; xn = xn->next[0]) {
    const Column& column = *xn->value;
    ReaderLock lock(&column.mu);
    fn(xn->key, column.version.load(std::memory_order_acquire),
       std::span<const std::pair<int32_t, uint64_t>>(column.y_blocks));
  }
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

}  // namespace skimap

#endif  // SKIMAP_SKIMAP_SEARCH_IMPL_H_
