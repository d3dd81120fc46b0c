// skimap-sim's dataset generator: presets, training sequences, test scenes, and the BOP +
// TUM output (layout in docs/sim.md).
//
// Output under out_dir:
//   camera.json, objects.json (obj_id -> name), dataset_info.json (preset, seed, options)
//   models/models_info.json, models/obj_XXXXXX.ply   (millimetres, vertex colours)
//   train/XXXXXX/   one folder per object id: orbits at several elevations ("variants",
//                   listed in variants.json), BOP scene files + TUM files
//   test/XXXXXX/    one folder per scene: BOP scene files, TUM files, scene_geometry.json
//
// Determinism: the output bytes depend only on the options (not on thread count or timing):
// every frame draws its noise from a stream seeded by (seed, sequence, frame).
//
// Thread safety: Generate() may run concurrently for different out_dirs.
#ifndef SKIMAP_SIM_GENERATOR_H_
#define SKIMAP_SIM_GENERATOR_H_

#include <cstdint>
#include <ostream>
#include <string>

#include "absl/status/statusor.h"
#include "sim/objects.h"

namespace skimap::sim {

// What to generate. Zero/negative counts mean "the preset's default".
struct GeneratorOptions {
  std::string out_dir;          // created if missing; existing files overwritten
  std::string preset = "mini";  // "mini", "sk" or "robot"
  uint64_t seed = 1;
  std::string texture_dir = kDefaultTextureDir;
  int scene_frames = 0;              // frames per test scene
  int train_frames = 0;              // frames per training variant (orbit)
  int scenes = -1;                   // number of test scenes (<= preset's)
  double speed_scale = 1;            // multiplies the trajectory speeds
  bool depth_noise = true;           // false: ideal depth (range limits only)
  std::string noise = "kinect";      // sensor model of the test scenes (docs/sim.md): "kinect"
                                     // or "harsh" (held-out: more depth noise, shorter range,
                                     // more dropouts, colour noise, auto-exposure drift) or
                                     // "tof" (time of flight: flying pixels at depth edges)
  int motion_blur = 0;               // 0/1: off; n >= 2: n sub-frames averaged
  bool train = true;                 // write train/
  bool models_only = false;          // write the root files and models/ only
  int threads = 2;                   // frames rendered in parallel
  std::ostream* progress = nullptr;  // progress lines, if set
};

// Summary of a run.
struct GeneratorStats {
  int frames = 0;         // images written (train + test)
  double seconds = 0;     // wall time
  double render_fps = 0;  // frames / seconds spent rendering only (all threads)
};

// Generates the dataset. kInvalidArgument for a bad preset/option, kNotFound for a missing
// texture folder, kInternal for I/O errors (the message names the file).
absl::StatusOr<GeneratorStats> Generate(const GeneratorOptions& options);

}  // namespace skimap::sim

#endif  // SKIMAP_SIM_GENERATOR_H_
