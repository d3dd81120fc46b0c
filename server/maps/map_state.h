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
// Every Apply marks the chunks it touched in the volume's dirty set; a snapshot writes
// those chunks only (incremental) and clears the sets.
//
// Thread safety: a plain value; LiveMap guards it.
#ifndef SERVER_MAPS_MAP_STATE_H_
#define SERVER_MAPS_MAP_STATE_H_

#include <cstdint>

#include "absl/container/flat_hash_set.h"
#include "server/maps/chunk_codec.h"
#include "server/maps/map_config.h"
#include "skimap/skimap.h"
#include "skimap/thread_pool.h"

namespace skimap::server {

using Volume = SkiMap<RGBWeightedVoxel>;
// Free-space evidence for maps with carve_free_space: one layer (z key 0) whose weight
// counts the frames whose rays crossed a column's band (perception/free_space.h).
using FreeVolume = SkiMap<WeightVoxel>;

// The chunks (chunk_codec.h) of one volume changed since the last snapshot capture.
using DirtyChunks = absl::flat_hash_set<ChunkCoord>;

struct MapState {
  // REQUIRES: config validated; pool (not owned) outlives the state or is null.
  MapState(const MapConfig& config, ThreadPool* pool)
      : rgb({.resolution = config.resolution, .pool = pool}),
        free({.resolution = config.resolution, .pool = pool}) {}

  Volume rgb;
  FreeVolume free;
  uint64_t frames = 0;            // frames integrated
  uint64_t journal_position = 0;  // last journal record applied (0: none, or no store)
  DirtyChunks dirty_rgb, dirty_free;

  // Calls fn(name, volume, dirty) for every volume, by the name it is stored under. Code
  // that must cover every volume (snapshots, reload, export) goes through here.
  template <class Fn>
  void ForEachVolume(Fn&& fn) {
    fn("rgb", rgb, dirty_rgb);
    fn("free", free, dirty_free);
  }
  template <class Fn>
  void ForEachVolume(Fn&& fn) const {
    fn("rgb", rgb, dirty_rgb);
    fn("free", free, dirty_free);
  }
};

}  // namespace skimap::server

#endif  // SERVER_MAPS_MAP_STATE_H_
