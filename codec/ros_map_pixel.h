// The pixel of an occupancy-grid cell in a ROS map_server image (the CLI's PGM files and
// the REST API's PGM / PNG pictures write the same bytes).
//
//   image[row][i] = RosMapPixel(cell, grid.inflation_radius() > 0);
//
// Trinary (map_saver's bytes): 205 unknown (-1), 0 occupied (>= 50), 254 free; map_server's
// p = (255 - v) / 255 reads them back with occupied_thresh 0.65 and free_thresh 0.196. A
// cost grid (0 free, 1-99 cost, 100 occupied, -1 unknown) is written for map_server's raw
// mode: the byte is the value, so -1 becomes 255 and reads back as -1.
//
// Thread safety: a pure function.
#ifndef CODEC_ROS_MAP_PIXEL_H_
#define CODEC_ROS_MAP_PIXEL_H_

#include <cstdint>

namespace skimap {

inline uint8_t RosMapPixel(int8_t cell, bool cost_grid) {
  if (cost_grid) return static_cast<uint8_t>(cell);
  return cell < 0 ? 205 : cell >= 50 ? 0 : 254;
}

}  // namespace skimap

#endif  // CODEC_ROS_MAP_PIXEL_H_
