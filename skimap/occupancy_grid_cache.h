// OccupancyGridCache: ComputeOccupancyGrid for a map that keeps being written, answering
// from the cells it computed before and recomputing only the x columns written since.
//
//   mutable OccupancyGridCache cache;                      // beside the map
//   absl::StatusOr<OccupancyGrid> g = cache.Compute(map, options);   // == ComputeOccupancyGrid
//
// It keeps, per x column of the map, the cell of every y of that column (a dense run over
// the column's y extent) and the versions SkiMap::ForEachColumnVersion gave the column and
// its blocks of 64 ys. A query reads the versions of the raster's x range, recomputes the
// y blocks whose version moved (a column it never saw: all of it), forgets the columns the
// map no longer has, and copies the cells out. A planner asking for the same band every few
// frames while robots map pays for the blocks the new frames touched, not for the raster. The bands
// and weight threshold of the last query are kept: a query with others starts over. Memory: a byte
// per (x, y) over each cached column's y extent, held until the cache is destroyed.
//
// The answer equals ComputeOccupancyGrid's on the same map state; the caller must keep
// writers out during Compute (a server's snapshot read lock) for the answer to be one
// state, as for ComputeOccupancyGrid.
//
// Thread safety: Compute may be called from several threads; they take turns.
#ifndef SKIMAP_OCCUPANCY_GRID_CACHE_H_
#define SKIMAP_OCCUPANCY_GRID_CACHE_H_

#include <algorithm>
#include <cstdint>
#include <limits>
#include <span>
#include <utility>
#include <vector>

#include "absl/container/flat_hash_map.h"
#include "absl/status/statusor.h"
#include "base/mutex.h"
#include "skimap/map_queries.h"

namespace skimap {

class OccupancyGridCache {
 public:
  template <Voxel V>
  absl::StatusOr<OccupancyGrid> Compute(const SkiMap<V>& map, const OccupancyGridOptions& opt);
  // x columns the last Compute refreshed, in part or whole (the rest came from the cache).
  size_t last_recomputed() {
    MutexLock lock(&mu_);
    return last_recomputed_;
  }

 private:
  using Blocks = std::vector<std::pair<int32_t, uint64_t>>;  // (y block, version), sorted
  struct XColumn {
    uint64_t version = 0;
    Blocks blocks;              // as last refreshed
    int32_t y0 = 0;             // key y of cells[0]
    std::vector<int8_t> cells;  // y0 .. y0 + size - 1
  };
  // Work of one query on one column: the map's versions, and which blocks to recompute.
  struct Refresh {
    int32_t x;
    uint64_t version;
    Blocks blocks;
    XColumn* column = nullptr;
    std::vector<int32_t> stale;  // blocks to recompute; empty: the whole column
  };
  template <Voxel V>
  static void Recompute(const SkiMap<V>& map, const internal::OccupancyBands& bands, Refresh* r);

  Mutex mu_;
  bool has_bands_ ABSL_GUARDED_BY(mu_) = false;
  internal::OccupancyBands bands_ ABSL_GUARDED_BY(mu_){};
  absl::flat_hash_map<int32_t, XColumn> columns_ ABSL_GUARDED_BY(mu_);
  size_t last_recomputed_ ABSL_GUARDED_BY(mu_) = 0;
};

template <Voxel V>
void OccupancyGridCache::Recompute(const SkiMap<V>& map, const internal::OccupancyBands& bands,
                                   Refresh* r) {
  constexpr int kShift = SkiMap<V>::kYBlockShift;
  XColumn& c = *r->column;
  auto compute = [&](int32_t lo, int32_t hi, std::vector<std::pair<int32_t, int8_t>>* cells) {
    map.ForEachColumn(r->x, r->x, lo, hi,
                      [&](int32_t, int32_t y, const typename SkiMap<V>::ZColumn& z) {
                        cells->emplace_back(y, internal::ColumnOccupancy<V>(z, bands));
                      });
  };
  std::vector<std::pair<int32_t, int8_t>> cells;
  if (r->stale.empty()) {  // the whole column
    compute(std::numeric_limits<int32_t>::min(), std::numeric_limits<int32_t>::max(), &cells);
    c.cells.clear();
    if (!cells.empty()) {
      c.y0 = cells.front().first;
      c.cells.assign(size_t(int64_t(cells.back().first) - c.y0 + 1), OccupancyGrid::kUnknown);
    }
  } else {
    // Widens the run to the stale blocks' ys, then clears and recomputes each block.
    int64_t lo = int64_t(r->stale.front()) << kShift;
    int64_t hi = ((int64_t(r->stale.back()) + 1) << kShift) - 1;
    if (!c.cells.empty()) {
      lo = std::min<int64_t>(lo, c.y0);
      hi = std::max<int64_t>(hi, int64_t(c.y0) + int64_t(c.cells.size()) - 1);
      if (lo < c.y0) c.cells.insert(c.cells.begin(), size_t(c.y0 - lo), OccupancyGrid::kUnknown);
    }
    c.y0 = int32_t(lo);
    c.cells.resize(size_t(hi - lo + 1), OccupancyGrid::kUnknown);
    for (int32_t block : r->stale) {
      const int64_t b0 = int64_t(block) << kShift, b1 = b0 + (int64_t{1} << kShift) - 1;
      std::fill(c.cells.begin() + (b0 - lo), c.cells.begin() + (b1 - lo + 1),
                OccupancyGrid::kUnknown);
      compute(int32_t(b0), int32_t(b1), &cells);
    }
  }
  for (const auto& [y, cell] : cells) c.cells[size_t(int64_t(y) - c.y0)] = cell;
  c.version = r->version;
  c.blocks = std::move(r->blocks);
}

template <Voxel V>
absl::StatusOr<OccupancyGrid> OccupancyGridCache::Compute(const SkiMap<V>& map,
                                                          const OccupancyGridOptions& opt) {
  absl::StatusOr<OccupancyGrid> grid = internal::UnknownOccupancyGrid(map, opt);
  if (!grid.ok() || grid->cells.empty()) return grid;
  OccupancyGrid& out = *grid;
  const RasterGeometry* geo = &out.geometry;
  const internal::OccupancyBands bands = internal::MakeOccupancyBands(map.grid(), opt);
  const int32_t x0 = geo->key_x0, x1 = geo->key_x0 + geo->width - 1;
  const int64_t y_lo = geo->key_y0, y_hi = int64_t(geo->key_y0) + geo->height - 1;

  MutexLock lock(&mu_);
  if (!has_bands_ || !(bands_ == bands)) {
    columns_.clear();
    bands_ = bands;
    has_bands_ = true;
  }
  // The raster's columns, and the ones written since this cache saw them.
  std::vector<int32_t> xs;
  std::vector<Refresh> refresh;
  const auto* cached = &columns_;  // (a lambda is analysed as if outside the lock)
  map.ForEachColumnVersion(x0, x1, [&](int32_t x, uint64_t version, auto y_blocks) {
    xs.push_back(x);
    auto it = cached->find(x);
    if (it != cached->end() && it->second.version == version) return;
    refresh.push_back({x, version, Blocks(y_blocks.begin(), y_blocks.end())});
  });
  // The cached columns the map no longer has (emptied by removals) go.
  for (auto it = columns_.begin(); it != columns_.end();) {
    if (it->first >= x0 && it->first <= x1 &&
        !std::binary_search(xs.begin(), xs.end(), it->first)) {
      columns_.erase(it++);
    } else {
      ++it;
    }
  }
  for (Refresh& r : refresh) columns_.try_emplace(r.x);
  // No insertion from here on: the pointers stay valid.
  size_t blocks = 0;
  for (Refresh& r : refresh) {
    r.column = &columns_.find(r.x)->second;
    if (r.column->cells.empty()) continue;  // new: the whole column
    const Blocks& had = r.column->blocks;
    for (const auto& [block, version] : r.blocks) {
      auto pos = std::lower_bound(
          had.begin(), had.end(), block,
          [](const std::pair<int32_t, uint64_t>& b, int32_t key) { return b.first < key; });
      if (pos == had.end() || pos->first != block || pos->second != version) {
        r.stale.push_back(block);
      }
    }
    // A column's blocks only grow while it lives: one the cache had and the map lacks means
    // the column was emptied and made again since, so all of it is recomputed.
    const bool recreated =
        !std::includes(r.blocks.begin(), r.blocks.end(), had.begin(), had.end(),
                       [](const auto& a, const auto& b) { return a.first < b.first; });
    if (recreated) {
      r.stale.clear();
      continue;
    }
    blocks += r.stale.size();
    if (r.stale.empty()) r.stale.push_back(r.blocks.empty() ? 0 : r.blocks.front().first);
  }
  last_recomputed_ = refresh.size();
  auto recompute = [&](size_t first, size_t last) {
    for (size_t i = first; i < last; ++i) Recompute(map, bands, &refresh[i]);
  };
  // The pool only for a large refill (a first query): it is shared with ingestion, and a
  // few blocks are quicker here than waiting for it.
  if (opt.pool != nullptr && opt.pool->workers() > 0 && refresh.size() >= 256 &&
      blocks < refresh.size()) {
    opt.pool->ParallelFor(refresh.size(), recompute);
  } else {
    recompute(0, refresh.size());
  }
  std::vector<std::pair<int32_t, XColumn*>> present;
  present.reserve(xs.size());
  for (int32_t x : xs) present.emplace_back(x, &columns_.find(x)->second);
  // Copied out a block of x columns at a time: the row-major raster is written one short
  // row run after another, each column read in order.
  constexpr size_t kBlock = 64;
  const size_t width = size_t(geo->width);
  for (size_t b = 0; b < present.size(); b += kBlock) {
    const size_t e = std::min(present.size(), b + kBlock);
    int64_t first = y_hi + 1, last = y_lo - 1;
    for (size_t i = b; i < e; ++i) {
      const XColumn& c = *present[i].second;
      first = std::min<int64_t>(first, std::max<int64_t>(y_lo, c.y0));
      last = std::max<int64_t>(
          last, std::min<int64_t>(y_hi, int64_t(c.y0) + int64_t(c.cells.size()) - 1));
    }
    for (int64_t y = first; y <= last; ++y) {
      int8_t* row = out.cells.data() + size_t(y - y_lo) * width;
      for (size_t i = b; i < e; ++i) {
        const XColumn& c = *present[i].second;
        const int64_t at = y - c.y0;
        if (at >= 0 && at < int64_t(c.cells.size()))
          row[present[i].first - x0] = c.cells[size_t(at)];
      }
    }
  }
  return grid;
}

}  // namespace skimap

#endif  // SKIMAP_OCCUPANCY_GRID_CACHE_H_
