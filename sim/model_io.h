// 3D models as users have them, read into a Mesh for rendering training views: PLY with
// vertex colours (BOP and YCB models, phone scans), OBJ with an MTL and texture images (CAD
// exports), glTF / GLB with embedded or external textures; anything else Assimp reads.
//
//   absl::StatusOr<Mesh> mesh = LoadModel("cereal.obj", {.units = ModelUnits::kAuto});
//
// Colour, per material: the diffuse texture (a file next to the model, or embedded) sampled
// at the vertices' texture coordinates; else the vertices' colours, each triangle drawn in
// the mean of its three (a palette texture, one texel per triangle); else the material's
// diffuse colour. The model's own frame is kept (poses are of the model frame), scaled to
// metres.
//
// Model files are hostile input: a file over limits.max_file_bytes, a model over
// limits.max_triangles, a PLY header that cannot be whole (dataset/model_points.h), a file
// Assimp cannot read, or one without a triangle is refused with InvalidArgument naming the
// file; textures are scaled down to limits.max_texture_side.
//
// Thread safety: reentrant.
#ifndef SKIMAP_SIM_MODEL_IO_H_
#define SKIMAP_SIM_MODEL_IO_H_

#include <cstddef>
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
};

// Parses "auto", "m" or "mm" (InvalidArgument naming `flag` otherwise).
absl::StatusOr<ModelUnits> ParseModelUnits(const std::string& text, const std::string& flag);

absl::StatusOr<Mesh> LoadModel(const std::string& path, const ModelOptions& options = {});

}  // namespace skimap::sim

#endif  // SKIMAP_SIM_MODEL_IO_H_
