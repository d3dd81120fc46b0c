#include "skimap/map_queries.h"

#include <algorithm>

namespace skimap {

absl::StatusOr<RasterGeometry> MakeRasterGeometry(const Grid& grid,
                                                  const std::optional<Region2D>& region,
                                                  const std::optional<KeyBox>& bounds,
                                                  int64_t max_cells) {
  RasterGeometry g;
  g.resolution = grid.resolution();
  int32_t x0, x1, y0, y1;
  if (region) {
    const Region2D& r = *region;
    if (!std::isfinite(r.min_x) || !std::isfinite(r.max_x) || !std::isfinite(r.min_y) ||
        !std::isfinite(r.max_y) || r.min_x > r.max_x || r.min_y > r.max_y) {
      return absl::InvalidArgumentError("region: need finite min <= max on x and y");
    }
    if (!grid.AxisToKey(r.min_x, grid.origin().x, &x0) ||
        !grid.AxisToKey(r.max_x, grid.origin().x, &x1) ||
        !grid.AxisToKey(r.min_y, grid.origin().y, &y0) ||
        !grid.AxisToKey(r.max_y, grid.origin().y, &y1)) {
      return absl::InvalidArgumentError("region: outside the map's key range");
    }
  } else if (bounds) {
    x0 = bounds->min.x, x1 = bounds->max.x, y0 = bounds->min.y, y1 = bounds->max.y;
  } else {
    g.origin_x = grid.origin().x;
    g.origin_y = grid.origin().y;
    return g;  // empty map: 0 x 0
  }
  const int64_t w = int64_t{x1} - x0 + 1, h = int64_t{y1} - y0 + 1;
  const int64_t limit = std::min(max_cells, kMaxRasterCells);
  if (w * h > limit) {
    return absl::ResourceExhaustedError(
        absl::StrCat("region: ", w, " x ", h, " cells exceeds the limit of ", limit, " cells"));
  }
  g.width = static_cast<int32_t>(w);
  g.height = static_cast<int32_t>(h);
  g.key_x0 = x0;
  g.key_y0 = y0;
  g.origin_x = grid.origin().x + x0 * grid.resolution();
  g.origin_y = grid.origin().y + y0 * grid.resolution();
  return g;
}

}  // namespace skimap
