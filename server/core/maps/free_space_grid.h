// Combining free-space evidence with the 2D occupancy grid of a carving map.
//
// Thread safety: a reader of `free` (call it under the map's snapshot lock, like the grid).
#ifndef SERVER_CORE_MAPS_FREE_SPACE_GRID_H_
#define SERVER_CORE_MAPS_FREE_SPACE_GRID_H_

#include "server/core/maps/live_map.h"
#include "skimap/map_queries.h"

namespace skimap::server {

// Marks kFree every kUnknown cell of `grid` whose column in `free` (one layer, see
// perception/free_space.h: frames whose rays crossed the map's band there) has at least
// `min_weight`. Occupied and free cells stay as they are: a surface in the band wins over
// free evidence, and seen floor is free already.
// REQUIRES: grid->geometry was made for free's grid (same resolution and origin).
void MarkCarvedCells(const FreeVolume& free, float min_weight, OccupancyGrid* grid);

}  // namespace skimap::server

#endif  // SERVER_CORE_MAPS_FREE_SPACE_GRID_H_
