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
    const auto [rows_first, rows_last] = column.ys.Range(box.min.y, box.max.y);
    for (auto* row = rows_first; row != rows_last; ++row) {
      const auto [first, last] = row->value.Range(box.min.z, box.max.z);
      for (auto* e = first; e != last; ++e) {
        fn(VoxelKey{xn->key, row->key, e->key}, e->value);
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
  // Columns are searched kGroup at a time, so that their cache misses overlap (a map's
  // columns are far apart in memory): the binary searches for each column's first row
  // y >= y0 advance in lockstep; then each column's rows in [y0, y1] are listed, with a
  // prefetch of the z run of every row kept; then the rows are scanned in (x, y, z) order.
  constexpr size_t kGroup = 32;
  using YEntry = typename YList::Entry;
  struct Col {
    const YList* ys;
    int32_t x, y0, y1;
    ColState state;
  };
  struct Row {
    const ZList* list;
    int32_t x, y, z0, z1;
    RowState state;
  };
  Col cols[kGroup];
  std::vector<Row> rows;
  auto run_group = [&](size_t n) {
    const YEntry* at[kGroup];
    size_t len[kGroup];
    size_t longest = 0;
    for (size_t i = 0; i < n; ++i) {
      at[i] = cols[i].ys->begin();
      len[i] = cols[i].ys->size();
      longest = std::max(longest, len[i]);
    }
    // Lower bounds by halving (each step a conditional move, not a branch on the key): a
    // step halves every column's range still longer than 1.
    for (; longest > 1; longest -= longest / 2) {
      for (size_t i = 0; i < n; ++i) {
        if (len[i] <= 1) continue;
        const size_t half = len[i] / 2;
        at[i] = at[i][half].key < cols[i].y0 ? at[i] + half : at[i];
        len[i] -= half;
      }
    }
    rows.clear();
    for (size_t i = 0; i < n; ++i) {
      const Col& col = cols[i];
      const YEntry* row = at[i] + (len[i] == 1 && at[i]->key < col.y0);
      for (const YEntry* end = col.ys->end(); row != end && row->key <= col.y1; ++row) {
        Row r;
        if (!row_range(std::as_const(col.state), row->key, &r.state, &r.z0, &r.z1)) continue;
        row->value.PrefetchHead();
        r.list = &row->value;
        r.x = col.x;
        r.y = row->key;
        rows.push_back(r);
      }
    }
    for (const Row& row : rows) {
      const auto [first, last] = row.list->Range(row.z0, row.z1);
      for (auto* e = first; e != last; ++e) {
        if (keep(row.state, e->key)) fn(VoxelKey{row.x, row.y, e->key}, e->value);
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
    if (!col_range(xn->key, &col.state, &col.y0, &col.y1)) continue;
    const Column& column = *xn->value;
    // Shared locks of a group are taken in ascending x; writers never hold a column lock
    // while waiting for another, so holding several cannot deadlock.
    locks.Add(&column);
    col.ys = &column.ys;
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
    const auto [first, last] = column.ys.Range(min_y, max_y);
    for (auto* row = first; row != last; ++row) fn(xn->key, row->key, ZColumn(row->value));
  }
}

}  // namespace skimap

#endif  // SKIMAP_SKIMAP_SEARCH_IMPL_H_
