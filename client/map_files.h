// Files written by the `skimap` CLI from query answers.
//
// ROS map_server map (WriteRosMap): FILE.yaml + FILE.pgm next to it. The PGM is binary
// (P5), 8-bit, trinary: 0 occupied, 254 free, 205 unknown (map_server reads p = (255 - v) /
// 255: 1.0 > occupied_thresh 0.65, 0.004 < free_thresh 0.196, 0.196 between them); a cost
// grid (inflation_radius > 0) holds the values themselves (0 free, 1-99 cost, 100 occupied,
// 255 unknown) for map_server's raw mode. Row 0 of the image is the grid's top row (largest
// y), as map_server expects. The YAML holds image, resolution, origin [x, y, yaw], negate 0,
// occupied_thresh 0.65, free_thresh 0.196, mode trinary (raw for a cost grid).
//
// Height map (WriteHeightMap): FILE.png (16-bit, value v > 0 means height
// z_offset + v * 0.001 m, 0 unknown) or FILE.tiff (32-bit float metres, NaN unknown), plus
// FILE.yaml beside it: resolution, origin [x, y] of the lower-left cell corner, width,
// height, encoding, z_offset, z_scale. Image row 0 is the top row (largest y), like the PGM.
//
// Voxels (WritePly): binary little-endian PLY, one vertex per voxel centre: float x y z,
// uchar red green blue, float weight.
//
// Thread safety: functions of their arguments; write different paths concurrently.
#ifndef CLIENT_MAP_FILES_H_
#define CLIENT_MAP_FILES_H_

#include <string>
#include <vector>

#include "absl/status/status.h"
#include "skimap/v1/queries.pb.h"

namespace skimap::client {

// yaml_path must end in ".yaml"; the PGM is yaml_path with ".pgm". Internal on I/O errors,
// InvalidArgument for a malformed grid.
absl::Status WriteRosMap(const v1::OccupancyGrid& grid, const std::string& yaml_path);

// path must end in ".png" or ".tiff"/".tif"; the sidecar is path with ".yaml".
absl::Status WriteHeightMap(const v1::HeightMap& map, const std::string& path);

absl::Status WritePly(const std::vector<v1::Voxel>& voxels, const std::string& path);

// `path` with its extension (from the last '.') replaced by `ext` (".pgm").
std::string ReplaceExtension(const std::string& path, const std::string& ext);

}  // namespace skimap::client

#endif  // CLIENT_MAP_FILES_H_
