// Combining free-space evidence with the 2D occupancy grid of a carving map.
//
// Thread safety: readers of `free` (call them under the map's snapshot lock, like the grid).
#ifndef SERVER_CORE_MAPS_FREE_SPACE_GRID_H_
#define SERVER_CORE_MAPS_FREE_SPACE_GRID_H_

#include <cstdint>

#include "server/core/maps/map_state.h"
#include "skimap/map_queries.h"

namespace skimap::server {

// Marks kFree every kUnknown cell of `grid` whose column in `free` (one layer of 4 × 4
// blocks, see perception/free_space.h: frames whose rays crossed the map's band there) has
// a count of at least `min_count`. Occupied and free cells stay as they are: a surface in
// the band wins over free evidence, and seen floor is free already.
// REQUIRES: grid->geometry was made for free's grid (same resolution and origin).
void MarkCarvedCells(const FreeVolume& free, uint32_t min_count, OccupancyGrid* grid);

// The columns with free-space evidence (a count > 0), over all blocks.
uint64_t CountFreeColumns(const FreeVolume& free);

}  // namespace skimap::server

#endif  // SERVER_CORE_MAPS_FREE_SPACE_GRID_H_
