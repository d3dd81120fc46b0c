// Obstacle inflation: an occupancy grid made cost-valued for planners that take costs
// (nav2 costmaps, move_base), as GetOccupancyGridRequest.inflation_radius asks.
//
//   InflateObstacles(0.3 / grid.geometry.resolution, &grid);
//
// Every free cell whose centre lies within r = `radius_cells` cells of an occupied cell's
// centre gets the cost 1 + round(98 * (r - d) / (r - 1)) for its distance d >= 1 in cells
// (99 beside the obstacle, falling linearly to 1 at the radius; 99 for r <= 1); the
// distance is OpenCV's exact Euclidean distance transform (cv::DIST_L2,
// cv::DIST_MASK_PRECISE). Occupied cells stay 100,
// unknown cells stay unknown (-1), free cells beyond the radius stay 0.
//
// Thread safety: a plain function over the caller's grid.
#ifndef SERVER_CORE_MAPS_GRID_INFLATION_H_
#define SERVER_CORE_MAPS_GRID_INFLATION_H_

#include "skimap/map_queries.h"

namespace skimap::server {

// REQUIRES: radius_cells > 0.
void InflateObstacles(double radius_cells, OccupancyGrid* grid);

}  // namespace skimap::server

#endif  // SERVER_CORE_MAPS_GRID_INFLATION_H_
