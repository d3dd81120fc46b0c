// Renders one sequence (a training orbit or a test scene) frame by frame, in parallel, into
// a BOP scene folder: rgb/, depth/, mask_visib/ images plus the scene JSON and TUM files.
//
// Thread safety: RenderSequence uses `threads` workers internally; the inputs must stay
// unchanged during the call.
#ifndef SKIMAP_SIM_SEQUENCE_H_
#define SKIMAP_SIM_SEQUENCE_H_

#include <Eigen/Geometry>
#include <cstdint>
#include <ostream>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "dataset/types.h"
#include "sim/depth_noise.h"
#include "sim/rasterizer.h"

namespace skimap::sim {

// One sequence to render.
struct SequenceSpec {
  std::string dir;                       // BOP scene folder to write
  std::string label;                     // for progress lines, e.g. "test/000001"
  std::vector<Instance> instances;       // everything in view
  std::vector<int> annotated;            // indices into instances (ids > 0) to annotate
  std::vector<int> obj_ids;              // BOP obj_id of each annotated instance
  std::vector<Eigen::Isometry3f> poses;  // world <- camera, one per frame
  dataset::CameraInfo camera;
  Lighting light;
  DepthNoise noise;
  float colour_noise = 2.0f;  // grey levels (sigma)
  // Auto-exposure: frame i's colour is scaled by 1 + exposure_drift * sin(2 pi t / 5 s + phase)
  // + U(-exposure_jitter, exposure_jitter) (phase and jitter from the seed); 0, 0: fixed.
  float exposure_drift = 0, exposure_jitter = 0;
  int motion_blur = 0;  // sub-frames (0/1 = off)
  double fps = 30;
  uint64_t seed = 1;  // noise stream: seeded per frame from this
};

// Timing of one sequence.
struct SequenceStats {
  int frames = 0;
  double render_seconds = 0;  // summed over workers: rasterization + noise only
  double wall_seconds = 0;
};

// Renders and writes every frame, then the scene files. Errors name the file.
absl::StatusOr<SequenceStats> RenderSequence(const SequenceSpec& spec, int threads,
                                             std::ostream* progress);

}  // namespace skimap::sim

#endif  // SKIMAP_SIM_SEQUENCE_H_
