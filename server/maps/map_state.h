// MapState: every volume of one map and its counters, as one value that the map's
// pipeline writes and queries read under the map's snapshot lock (live_map.h).
//
//   map.Read([](const MapState& s) { return ComputeOccupancyGrid(s.rgb, options); });
//
// Volumes (DESIGN.md): `rgb` fed by every depth pixel; `free` the free-space evidence of
// carving maps (empty otherwise). The recognition volumes (labels, hypotheses, instances)
// join here as their stages appear, so that readers, the journal and snapshots see every
// volume through one door.
//
// Thread safety: a plain value; LiveMap guards it.
#ifndef SERVER_MAPS_MAP_STATE_H_
#define SERVER_MAPS_MAP_STATE_H_

#include <cstdint>

#include "server/maps/map_config.h"
#include "skimap/skimap.h"
#include "skimap/thread_pool.h"

namespace skimap::server {

using Volume = SkiMap<RGBWeightedVoxel>;
// Free-space evidence for maps with carve_free_space: one layer (z key 0) whose weight
// counts the frames whose rays crossed a column's band (perception/free_space.h).
using FreeVolume = SkiMap<WeightVoxel>;

struct MapState {
  // REQUIRES: config validated; pool (not owned) outlives the state or is null.
  MapState(const MapConfig& config, ThreadPool* pool)
      : rgb({.resolution = config.resolution, .pool = pool}),
        free({.resolution = config.resolution, .pool = pool}) {}

  Volume rgb;
  FreeVolume free;
  uint64_t frames = 0;  // frames integrated
};

}  // namespace skimap::server

#endif  // SERVER_MAPS_MAP_STATE_H_
