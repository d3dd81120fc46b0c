// Fuzz target: 3D model files (sim/model_io.h, what `skimap objects add` and the server's
// model renderer read) and one rendered training view of what they give.
//
// Input: one control byte choosing the extension (obj, ply, gltf, glb), then the file's
// bytes, written to a file of that name in a private folder (Assimp reads by path). The
// limits are small (1 MiB, 20 000 triangles, 64-pixel textures, 5 s for the reader, on
// which Assimp loops on some files) so a unit stays fast. The reader runs in a child
// process as in production; libFuzzer sees only this process's coverage.
// Invariants: a model that loads has a triangle, finite vertices, a texture index per
// triangle within its textures and texture coordinates per vertex; an error names the file.
#include <unistd.h>

#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <system_error>

#include "sim/model_io.h"
#include "sim/training_views.h"
#include "tests/fuzz/fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace skimap;
  namespace fs = std::filesystem;
  static const fs::path dir = [] {
    fs::path d = fs::temp_directory_path() / ("skimap_model_fuzz_" + std::to_string(getpid()));
    fs::create_directories(d);
    return d;
  }();
  // Removed when libFuzzer exits normally; a crash keeps it, beside its artifact.
  static const bool cleanup = std::atexit([] {
                                std::error_code ec;
                                fs::remove_all(dir, ec);
                              }) == 0;
  (void)cleanup;
  fuzz::FuzzInput in(data, size);
  constexpr const char* kExtensions[] = {"obj", "ply", "gltf", "glb"};
  const fs::path path = dir / (std::string("model.") + kExtensions[in.U8() % 4]);
  const std::string_view bytes = in.Rest();
  std::ofstream(path, std::ios::binary | std::ios::trunc).write(bytes.data(), bytes.size());
  absl::StatusOr<sim::Mesh> mesh = sim::LoadModel(path.string(), {.max_file_bytes = 1 << 20,
                                                                  .max_triangles = 20000,
                                                                  .max_texture_side = 64,
                                                                  .max_seconds = 5});
  fs::remove(path);
  if (!mesh.ok()) {
    if (mesh.status().message().find(path.string()) == std::string::npos) {
      fuzz::Fail("an error that does not name the file");
    }
    return 0;
  }
  if (mesh->triangles.empty()) fuzz::Fail("a model without a triangle");
  if (mesh->uvs.size() != mesh->positions.size()) fuzz::Fail("uvs per vertex");
  if (mesh->tri_texture.size() != mesh->triangles.size()) fuzz::Fail("a texture per triangle");
  for (int t : mesh->tri_texture) {
    if (t < 0 || t >= static_cast<int>(mesh->textures.size())) fuzz::Fail("texture index");
  }
  for (const auto& tri : mesh->triangles) {
    for (int k = 0; k < 3; ++k) {
      if (tri[k] < 0 || tri[k] >= static_cast<int>(mesh->positions.size())) {
        fuzz::Fail("vertex index");
      }
    }
  }
  for (const Eigen::Vector3f& p : mesh->positions) {
    if (!p.allFinite()) fuzz::Fail("a vertex that is not finite");
  }
  if (mesh->Diameter() > 0 && mesh->Diameter() < 1e4f) {
    const dataset::Intrinsics K{40, 40, 31.5, 23.5, 64, 48};
    (void)sim::RenderTrainingViews(*mesh, K, {.elevations_deg = {30}, .azimuths = 1});
  }
  return 0;
}
