// Frame stages: the ordered steps that turn one decoded frame into changes of a MapState.
//
//   std::vector<std::unique_ptr<FrameStage>> stages = MakeFrameStages(config, grid, pool);
//   for (auto& s : stages) s->Stage(frame, FrameStage::kAdd);     // outside the lock
//   { WriterLock l(&mu); for (auto& s : stages) s->Apply(&state); }
//
// A stage's contribution of a frame is a delta that can be subtracted exactly (it is
// rebuilt deterministically from the frame and its pose): Stage(frame, kRemove) with the old
// pose and Stage(frame, kAdd) with the new one move a frame, for any number of frames, and
// Apply makes every staged change visible at once (a pose update never shows half done).
// Staged contributions of several frames are merged per voxel, so what a stage holds is
// bounded by the distinct voxels involved, not by the number of frames (a pose update).
// Frames appended as a group (one journal append for the frames queued behind each other)
// are sealed one by one instead: each is applied as its own integration, in order, so the
// volume sums exactly what applying them one at a time would (the same float additions).
//
// Stages today: integration into `rgb` (perception/frame_integrator.h) and, for carving
// maps, free-space evidence into `free` (perception/free_space.h). Recognition adds its own.
//
// Thread safety: a stage belongs to one map's worker thread; Apply runs under the map's
// exclusive snapshot lock.
#ifndef SERVER_CORE_MAPS_FRAME_STAGES_H_
#define SERVER_CORE_MAPS_FRAME_STAGES_H_

#include <memory>
#include <vector>

#include "perception/frame_integrator.h"
#include "perception/rgbd_frame.h"
#include "server/core/maps/map_config.h"
#include "server/core/maps/map_state.h"

namespace skimap::server {

class FrameStage {
 public:
  enum Sign { kAdd, kRemove };
  virtual ~FrameStage() = default;

  // Builds the frame's contribution with frame.pose and stages it with `sign`. Returns the
  // back-projection counts when the stage has them (zeros otherwise).
  virtual perception::IntegrationStats Stage(const perception::RgbdFrame& frame, Sign sign) = 0;
  // Ends the frame staged last: it is applied on its own, after the frames sealed before
  // it and before anything staged after it.
  virtual void Seal() = 0;
  // Applies everything staged since the last Apply to `state`, removals first, then the
  // sealed frames in order, then what is staged unsealed; clears it. `per_sealed` (may be
  // null) gets each sealed frame's own stats added at its index (resized to fit).
  virtual WriteStats Apply(MapState* state, std::vector<WriteStats>* per_sealed = nullptr) = 0;
  // Drops what is staged without applying it.
  virtual void Clear() = 0;
};

// The stages of a map with `config`, in order. `grid` is the map's voxel grid (every
// volume of a map shares it); `pool` (not owned, may be null) runs the batch work.
std::vector<std::unique_ptr<FrameStage>> MakeFrameStages(const MapConfig& config, const Grid& grid,
                                                         ThreadPool* pool);

}  // namespace skimap::server

#endif  // SERVER_CORE_MAPS_FRAME_STAGES_H_
