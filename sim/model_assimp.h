// The Assimp side of sim/model_io.h, run only in the model reader's child process (Assimp
// aborts or crashes on some malformed files: tests/fuzz/model_file_fuzz.cc found a PLY in
// seconds). Reads the model with only the kModelFormats importers and with file access
// limited to the model's folder; textures come back as decoded, within texture_budget
// bytes in all (a texture past it is dropped: the material's colour is used). Positions
// in the file's units; nothing validated beyond Assimp's own checks (model_io.cc does).
//
// Thread safety: reentrant.
#ifndef SKIMAP_SIM_MODEL_ASSIMP_H_
#define SKIMAP_SIM_MODEL_ASSIMP_H_

#include <cstddef>
#include <string>

#include "absl/status/statusor.h"
#include "sim/mesh.h"

namespace skimap::sim {

// The formats read, by extension: every other Assimp importer is dropped, so a hostile
// file cannot reach a loader nobody here needs (Assimp reads 40-odd formats).
inline constexpr const char* kModelFormats[] = {"obj", "ply", "gltf", "glb"};

absl::StatusOr<Mesh> ReadModelWithAssimp(const std::string& path, size_t max_triangles,
                                         size_t texture_budget);

}  // namespace skimap::sim

#endif  // SKIMAP_SIM_MODEL_ASSIMP_H_
