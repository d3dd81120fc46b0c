// Pictures of the 2D rasters for REST clients, encoded with OpenCV (imencode). Image row 0
// is the raster's last row (largest y), so the picture has north up, as ROS map_server
// and the skimap CLI write them (client/map_files.h).
//
//   absl::StatusOr<std::string> pgm = EncodeOccupancyGrid(grid, RasterFormat::kPgm);
//
// Thread safety: pure functions.
#ifndef SERVER_HTTP_RASTER_IMAGES_H_
#define SERVER_HTTP_RASTER_IMAGES_H_

#include <string>

#include "absl/status/statusor.h"
#include "skimap/v1/queries.pb.h"

namespace skimap::server {

enum class RasterFormat { kJson, kPgm, kPng };

// The grid as an 8-bit greyscale image with ROS map_server's trinary pixels: 0 occupied
// (cells >= 50), 254 free, 205 unknown. kPgm: binary PGM (P5, maxval 255); kPng: PNG.
// FailedPrecondition for a grid without cells (nothing to draw); InvalidArgument if its
// data size differs from width x height.
absl::StatusOr<std::string> EncodeOccupancyGrid(const v1::OccupancyGrid& grid, RasterFormat format);

// The height map as a 16-bit greyscale PNG: pixel = round((z - z_offset) / 0.001 m), 0
// where unknown; *z_offset is set 1 mm below the lowest height (every known cell >= 1),
// as `skimap heightmap -o FILE.png` writes it. Errors as EncodeOccupancyGrid.
absl::StatusOr<std::string> EncodeHeightMapPng(const v1::HeightMap& map, double* z_offset);

}  // namespace skimap::server

#endif  // SERVER_HTTP_RASTER_IMAGES_H_
