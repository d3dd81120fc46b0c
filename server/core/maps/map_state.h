// MapState: every volume of one map and its counters, as one value that the map's
// pipeline writes and queries read under the map's snapshot lock (live_map.h).
//
//   map.Read([](const MapState& s) { return s.grid_cache.Compute(s.rgb, options); });
//
// Volumes (DESIGN.md): `rgb` fed by every depth pixel; `free` the free-space evidence of
// carving maps (empty otherwise); for maps with recognition (docs/recognition.md) `labels`
// (MultiLabelVoxel: verified feature classes), `hypotheses` (local 6-DOF hypotheses by
// position) and `instances` (instance estimates by position, with stable ids), each at
// its own resolution. Readers, snapshots and reload see every volume through one door
// (ForEachVolume).
//
// Every Apply marks the chunks it touched in the volume's dirty set; a snapshot writes
// those chunks only (incremental) and clears the sets.
//
// Thread safety: a plain value; LiveMap guards it.
#ifndef SERVER_CORE_MAPS_MAP_STATE_H_
#define SERVER_CORE_MAPS_MAP_STATE_H_

#include <cstdint>

#include "absl/container/flat_hash_map.h"
#include "absl/container/flat_hash_set.h"
#include "base/thread_pool.h"
#include "server/core/maps/grid_views.h"
#include "server/core/maps/map_config.h"
#include "server/core/recognition/instance_log.h"
#include "server/core/transfer/chunk_codec.h"
#include "skimap/free_columns_voxel.h"
#include "skimap/hypotheses_voxel.h"
#include "skimap/label_voxel.h"
#include "skimap/occupancy_grid_cache.h"
#include "skimap/skimap.h"

namespace skimap::server {

using Volume = SkiMap<RGBWeightedVoxel>;
// Free-space evidence for maps with carve_free_space: one layer (z key 0) of 4 × 4 blocks
// of columns, each column's count the frames whose rays crossed its band
// (perception/free_space.h, skimap/free_columns_voxel.h).
using FreeVolume = SkiMap<FreeColumnsVoxel>;

using LabelsVolume = SkiMap<MultiLabelVoxel>;
using HypothesesVolume = SkiMap<HypothesesVoxel>;
using InstancesVolume = SkiMap<InstancesVoxel>;

// The chunks (chunk_codec.h) of one volume changed since the last snapshot capture.
using DirtyChunks = absl::flat_hash_set<ChunkCoord>;

// Recognition's counters and indexes beside its volumes.
struct RecognitionState {
  uint64_t recognized_frames = 0;  // frames whose labels are in `labels`
  uint64_t next_instance_id = 1;   // ids are never reused (persisted: map_meta.h)
  // The object database the labels were made with (RecognitionModel::fingerprint); 0:
  // none yet. Persisted, so that a map reloaded under another database can tell.
  uint64_t fingerprint = 0;
  absl::flat_hash_map<uint64_t, VoxelKey> instance_keys;  // id -> its key in `instances`
  InstanceLog log;
  bool meta_dirty = false;  // counters changed since the last snapshot capture
};

struct MapState {
  // REQUIRES: config validated; pool (not owned) outlives the state or is null.
  MapState(const MapConfig& config, ThreadPool* pool)
      : rgb({.resolution = config.resolution, .pool = pool}),
        free({.resolution = config.resolution, .pool = pool}),
        labels({.resolution = config.recognition.labels_resolution}),
        hypotheses({.resolution = config.recognition.hypotheses_resolution}),
        instances({.resolution = config.recognition.instances_resolution}),
        grid_views(GridViews::Options{.min_depth = config.integration.min_depth}) {}

  Volume rgb;
  FreeVolume free;
  LabelsVolume labels;
  HypothesesVolume hypotheses;
  InstancesVolume instances;
  uint64_t frames = 0;            // frames integrated
  uint64_t journal_position = 0;  // last journal record applied (0: none, or no store)
  DirtyChunks dirty_rgb, dirty_free, dirty_labels, dirty_hypotheses, dirty_instances;
  RecognitionState recognition;
  // The latest depth from each vantage point, for the grid's seen-through test
  // (grid_views.h); not persisted.
  GridViews grid_views;
  // The occupancy grid of `rgb` as last asked, recomputed per written column (queries
  // reading the state fill it; it has its own lock).
  mutable OccupancyGridCache grid_cache;

  // Calls fn(name, volume, dirty) for every volume, by the name it is stored under. Code
  // that must cover every volume (snapshots, reload, export) goes through here.
  template <class Fn>
  void ForEachVolume(Fn&& fn) {
    fn("rgb", rgb, dirty_rgb);
    fn("free", free, dirty_free);
    fn("labels", labels, dirty_labels);
    fn("hypotheses", hypotheses, dirty_hypotheses);
    fn("instances", instances, dirty_instances);
  }
  template <class Fn>
  void ForEachVolume(Fn&& fn) const {
    fn("rgb", rgb, dirty_rgb);
    fn("free", free, dirty_free);
    fn("labels", labels, dirty_labels);
    fn("hypotheses", hypotheses, dirty_hypotheses);
    fn("instances", instances, dirty_instances);
  }
};

// Marks the chunks of `items` (sorted by key) in `dirty`: one set insert per run.
template <class Items>
void MarkDirtyChunks(const Items& items, DirtyChunks* dirty) {
  bool first = true;
  ChunkCoord last;
  for (const auto& item : items) {
    const ChunkCoord c = ChunkOf(item.key);
    if (first || !(c == last)) dirty->insert(c);
    first = false;
    last = c;
  }
}

}  // namespace skimap::server

#endif  // SERVER_CORE_MAPS_MAP_STATE_H_
