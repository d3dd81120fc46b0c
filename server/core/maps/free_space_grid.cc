#include "server/core/maps/free_space_grid.h"

namespace skimap::server {

void MarkCarvedCells(const FreeVolume& free, float min_weight, OccupancyGrid* grid) {
  const RasterGeometry& geo = grid->geometry;
  if (grid->cells.empty() || free.empty()) return;
  free.ForEachColumn(
      geo.key_x0, geo.key_x0 + geo.width - 1, geo.key_y0, geo.key_y0 + geo.height - 1,
      [&](int32_t kx, int32_t ky, const FreeVolume::ZColumn& column) {
        int8_t& cell = grid->cells[size_t(ky - geo.key_y0) * geo.width + (kx - geo.key_x0)];
        if (cell != OccupancyGrid::kUnknown) return;
        bool crossed = false;
        column.ForEach(
            [&](int32_t, const WeightVoxel& v) { crossed = crossed || v.Weight() >= min_weight; });
        if (crossed) cell = OccupancyGrid::kFree;
      });
}

}  // namespace skimap::server
