// 3D models as users have them, read into a Mesh for rendering training views: PLY with
// vertex colours (BOP and YCB models, phone scans), OBJ with an MTL and texture images (CAD
// exports), glTF / GLB with embedded or external textures. Only these four formats are
// read (by the file's extension; Assimp's other importers are dropped), and files the
// model names (MTL, textures, glTF buffers) only from the model's folder.
//
//   absl::StatusOr<Mesh> mesh = LoadModel("cereal.obj", {.units = ModelUnits::kAuto});
//
// Colour, per material: the diffuse texture (a file next to the model, or embedded) sampled
// at the vertices' texture coordinates; else the vertices' colours, each triangle drawn in
// the mean of its three (a palette texture, one texel per triangle); else the material's
// diffuse colour. The model's own frame is kept (poses are of the model frame), scaled to
// metres.
//
// Model files are hostile input. Assimp reads them in a child process (fork) limited to
// max_seconds of CPU and wall time and max_memory_bytes of address space; what it answers
// is checked here (every count and index). A file over max_file_bytes, a model over
// max_triangles, another extension, a PLY header that cannot be whole
// (dataset/model_points.h), a file Assimp cannot read or dies on, one over the limits or
// without a triangle, a vertex that is not finite: InvalidArgument naming the file.
// Textures are scaled down to max_texture_side.
//
// Thread safety: reentrant, but LoadModel forks: call it before the process starts other
// threads (a gRPC channel's, say), as `skimap objects add` and skimap-model-views do; a
// lock another thread held at the fork stays held in the child (seen: a hang under ASan
// with a gRPC client open). The child runs only Assimp and OpenCV's image decoders and
// leaves with _exit.
#ifndef SKIMAP_SIM_MODEL_IO_H_
#define SKIMAP_SIM_MODEL_IO_H_

#include <cstddef>
#include <cstdint>
#include <string>

#include "absl/status/statusor.h"
#include "sim/mesh.h"

namespace skimap::sim {

enum class ModelUnits {
  kAuto,  // millimetres when the bounding box's diagonal exceeds 10 units, else metres
  kMetres,
  kMillimetres,  // BOP models
};

struct ModelOptions {
  ModelUnits units = ModelUnits::kAuto;
  size_t max_file_bytes = size_t{256} << 20;
  size_t max_triangles = 2'000'000;
  int max_texture_side = 2048;
  int max_seconds = 120;                          // the reader's CPU and wall time
  uint64_t max_memory_bytes = uint64_t{4} << 30;  // the reader's address space
};

// Parses "auto", "m" or "mm" (InvalidArgument naming `flag` otherwise).
absl::StatusOr<ModelUnits> ParseModelUnits(const std::string& text, const std::string& flag);

absl::StatusOr<Mesh> LoadModel(const std::string& path, const ModelOptions& options = {});

// Limits the calling process to `cpu_seconds` of CPU time (then SIGXCPU) and
// `memory_bytes` of address space; the latter not in a sanitizer build (sanitizers reserve
// terabytes of address space up front). What LoadModel's reader and skimap-model-views do
// before they read a model. Internal if setrlimit fails.
absl::Status LimitThisProcess(int cpu_seconds, uint64_t memory_bytes);

}  // namespace skimap::sim

#endif  // SKIMAP_SIM_MODEL_IO_H_
