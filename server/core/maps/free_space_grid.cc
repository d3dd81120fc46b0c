#include "server/core/maps/free_space_grid.h"

#include <algorithm>

namespace skimap::server {

void MarkCarvedCells(const FreeVolume& free, uint32_t min_count, OccupancyGrid* grid) {
  const RasterGeometry& geo = grid->geometry;
  if (grid->cells.empty() || free.empty()) return;
  constexpr int32_t kSide = FreeColumnsVoxel::kSide;
  const int32_t x0 = geo.key_x0, x1 = geo.key_x0 + geo.width - 1;
  const int32_t y0 = geo.key_y0, y1 = geo.key_y0 + geo.height - 1;
  // Blocks are keyed by their lowest column: those overlapping the grid start at most
  // kSide - 1 keys before it.
  free.ForEachColumn(
      FreeColumnsVoxel::BlockKey(x0, y0).x, x1, FreeColumnsVoxel::BlockKey(x0, y0).y, y1,
      [&](int32_t bx, int32_t by, const FreeVolume::ZColumn& column) {
        column.ForEach([&](int32_t, const FreeColumnsVoxel& block) {
          for (int32_t kx = std::max(bx, x0); kx <= std::min(bx + kSide - 1, x1); ++kx) {
            for (int32_t ky = std::max(by, y0); ky <= std::min(by + kSide - 1, y1); ++ky) {
              if (block.counts[FreeColumnsVoxel::Index(kx, ky)] < min_count) continue;
              int8_t& cell = grid->cells[size_t(ky - y0) * geo.width + size_t(kx - x0)];
              if (cell == OccupancyGrid::kUnknown) cell = OccupancyGrid::kFree;
            }
          }
        });
      });
}

uint64_t CountFreeColumns(const FreeVolume& free) {
  uint64_t columns = 0;
  free.ForEach([&](const VoxelKey&, const FreeColumnsVoxel& block) { columns += block.Columns(); });
  return columns;
}

}  // namespace skimap::server
