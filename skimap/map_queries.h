// 2.5D height maps and 2D occupancy grids computed from a SkiMap, one pass over its
// (x, y) columns (the multi-level query of the SkiMap paper).
//
// Layout of both rasters (nav_msgs/OccupancyGrid and grid_map conventions): cells of the
// map's resolution, row-major with x fastest, cell (0, 0) has its lower-left corner at
// (origin_x, origin_y), so cell (i, j) covers [origin_x + i*res, origin_x + (i+1)*res) in x.
// A region, when given, is a world-frame rectangle; it is widened to whole cells.
//
// Thread safety: readers of the map (safe while it is being written; see skimap.h). With
// Options::pool they use its threads; do not call them from inside that pool's tasks.
#ifndef SKIMAP_MAP_QUERIES_H_
#define SKIMAP_MAP_QUERIES_H_

#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "base/thread_pool.h"
#include "skimap/skimap.h"

namespace skimap {

// World-frame rectangle, metres, bounds inclusive.
struct Region2D {
  double min_x = 0, min_y = 0, max_x = 0, max_y = 0;
};

// Largest raster a query may produce (cells), to keep a bad request from taking the server.
inline constexpr int64_t kMaxRasterCells = int64_t{1} << 28;

struct RasterGeometry {
  double resolution = 0;
  double origin_x = 0, origin_y = 0;  // lower-left corner of cell (0, 0)
  int32_t width = 0, height = 0;      // cells along x, along y
  int32_t key_x0 = 0, key_y0 = 0;     // voxel key of cell (0, 0)
};

struct HeightMap {
  RasterGeometry geometry;
  std::vector<float> heights;  // metres (voxel centre z of the top surface); NaN = unknown
};

struct HeightMapOptions {
  std::optional<Region2D> region;       // default: the map's bounds
  float min_weight = 0;                 // voxels with Weight() < min_weight are ignored
  ThreadPool* pool = nullptr;           // splits the raster's x range over its threads (not owned)
  int64_t max_cells = kMaxRasterCells;  // larger rasters: ResourceExhausted, nothing built
};

struct OccupancyGrid {
  static constexpr int8_t kUnknown = -1, kFree = 0, kOccupied = 100;
  RasterGeometry geometry;
  std::vector<int8_t> cells;  // kUnknown / kFree / kOccupied
};

struct OccupancyGridOptions {
  std::optional<Region2D> region;  // default: the map's bounds
  // A cell is occupied when a voxel centre lies in [band_min_z, band_max_z] (the robot's
  // height band) ...
  double band_min_z = 0.05;
  double band_max_z = 1.5;
  // ... free when nothing is in the band but the floor was seen: a voxel centre in
  // [floor_min_z, band_min_z); unknown otherwise.
  double floor_min_z = -0.3;
  float min_weight = 0;                 // voxels with Weight() < min_weight are ignored
  ThreadPool* pool = nullptr;           // splits the raster's x range over its threads (not owned)
  int64_t max_cells = kMaxRasterCells;  // larger rasters: ResourceExhausted, nothing built
};

// Cell geometry for a region (or the map's bounds). InvalidArgument for a bad region,
// ResourceExhausted above min(max_cells, kMaxRasterCells), decided from the geometry alone
// before anything is allocated; an empty map without region gives 0x0.
absl::StatusOr<RasterGeometry> MakeRasterGeometry(const Grid& grid,
                                                  const std::optional<Region2D>& region,
                                                  const std::optional<KeyBox>& bounds,
                                                  int64_t max_cells = kMaxRasterCells);

namespace internal {
// fn(kx, ky, ZColumn) for every non-empty column of the raster; with a pool, slabs of x run
// on its threads at once (fn then runs concurrently, for distinct columns).
template <Voxel V, class Fn>
void ForEachRasterColumn(const SkiMap<V>& map, const RasterGeometry& g, ThreadPool* pool, Fn&& fn) {
  const int32_t y1 = g.key_y0 + g.height - 1;
  auto slab = [&](size_t first, size_t last) {
    if (first < last) {
      map.ForEachColumn(g.key_x0 + int32_t(first), g.key_x0 + int32_t(last) - 1, g.key_y0, y1, fn);
    }
  };
  if (pool == nullptr || pool->workers() == 0 || g.width < 64) {
    slab(0, size_t(g.width));
  } else {
    pool->ParallelFor(size_t(g.width), slab);
  }
}

// An occupancy grid's z bands in keys: a column is occupied with a voxel in [band0, band1],
// else free with one in [floor0, floor1].
struct OccupancyBands {
  int32_t band0, band1, floor0, floor1;
  float min_weight;
  friend bool operator==(const OccupancyBands&, const OccupancyBands&) = default;
};
inline OccupancyBands MakeOccupancyBands(const Grid& grid, const OccupancyGridOptions& opt) {
  OccupancyBands b;
  grid.CenterRange(opt.band_min_z, opt.band_max_z, grid.origin().z, &b.band0, &b.band1);
  grid.CenterRange(opt.floor_min_z, opt.band_min_z, grid.origin().z, &b.floor0, &b.floor1);
  if (b.floor1 >= b.band0) b.floor1 = b.band0 - 1;  // a centre exactly at band_min_z is in the band
  b.min_weight = opt.min_weight;
  return b;
}
// The cell of one (x, y) column: kOccupied, kFree or kUnknown.
template <Voxel V>
int8_t ColumnOccupancy(const typename SkiMap<V>::ZColumn& column, const OccupancyBands& b) {
  bool occupied = false, floor = false;
  column.ForEachInRange(b.floor0, b.band1, [&](int32_t kz, const V& v) {
    if (v.Weight() < b.min_weight) return;
    if (kz >= b.band0) {
      occupied = true;
    } else if (kz <= b.floor1) {
      floor = true;
    }
  });
  return occupied ? OccupancyGrid::kOccupied
         : floor  ? OccupancyGrid::kFree
                  : OccupancyGrid::kUnknown;
}
}  // namespace internal

template <Voxel V>
absl::StatusOr<HeightMap> ComputeHeightMap(const SkiMap<V>& map, const HeightMapOptions& opt) {
  absl::StatusOr<RasterGeometry> geo = MakeRasterGeometry(
      map.grid(), opt.region, opt.region ? std::nullopt : map.FootprintBounds(), opt.max_cells);
  if (!geo.ok()) return geo.status();
  HeightMap out{*geo, std::vector<float>(size_t(geo->width) * size_t(geo->height),
                                         std::numeric_limits<float>::quiet_NaN())};
  if (out.heights.empty()) return out;
  const Grid& grid = map.grid();
  internal::ForEachRasterColumn(
      map, *geo, opt.pool, [&](int32_t kx, int32_t ky, const typename SkiMap<V>::ZColumn& column) {
        std::optional<int32_t> top;
        // Usually the highest voxel qualifies: O(log n) instead of a scan.
        if (const auto [kz, v] = column.Top(); v->Weight() >= opt.min_weight) {
          top = kz;
        } else {
          column.ForEach([&](int32_t kz, const V& v) {
            if (v.Weight() >= opt.min_weight) top = kz;
          });
        }
        if (!top) return;
        const size_t i = size_t(ky - geo->key_y0) * geo->width + (kx - geo->key_x0);
        out.heights[i] = static_cast<float>(grid.AxisCenter(*top, grid.origin().z));
      });
  return out;
}

namespace internal {
// The checks and the all-unknown raster every occupancy grid starts from: InvalidArgument
// for bad bands, MakeRasterGeometry's errors.
template <Voxel V>
absl::StatusOr<OccupancyGrid> UnknownOccupancyGrid(const SkiMap<V>& map,
                                                   const OccupancyGridOptions& opt) {
  if (!(opt.band_min_z <= opt.band_max_z) || !(opt.floor_min_z <= opt.band_min_z)) {
    return absl::InvalidArgumentError(
        "z band: need floor_min_z <= band_min_z <= band_max_z (all finite)");
  }
  absl::StatusOr<RasterGeometry> geo = MakeRasterGeometry(
      map.grid(), opt.region, opt.region ? std::nullopt : map.FootprintBounds(), opt.max_cells);
  if (!geo.ok()) return geo.status();
  return OccupancyGrid{
      *geo, std::vector<int8_t>(size_t(geo->width) * size_t(geo->height), OccupancyGrid::kUnknown)};
}
}  // namespace internal

template <Voxel V>
absl::StatusOr<OccupancyGrid> ComputeOccupancyGrid(const SkiMap<V>& map,
                                                   const OccupancyGridOptions& opt) {
  absl::StatusOr<OccupancyGrid> grid = internal::UnknownOccupancyGrid(map, opt);
  if (!grid.ok() || grid->cells.empty()) return grid;
  OccupancyGrid& out = *grid;
  const RasterGeometry* geo = &out.geometry;
  const internal::OccupancyBands bands = internal::MakeOccupancyBands(map.grid(), opt);
  internal::ForEachRasterColumn(
      map, *geo, opt.pool, [&](int32_t kx, int32_t ky, const typename SkiMap<V>::ZColumn& column) {
        const size_t i = size_t(ky - geo->key_y0) * geo->width + (kx - geo->key_x0);
        out.cells[i] = internal::ColumnOccupancy<V>(column, bands);
      });
  return grid;
}

}  // namespace skimap

#endif  // SKIMAP_MAP_QUERIES_H_
