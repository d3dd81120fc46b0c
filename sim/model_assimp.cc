// Assimp scenes into Meshes, in the model reader's child process. See model_assimp.h.
#include "sim/model_assimp.h"

#include <assimp/BaseImporter.h>
#include <assimp/DefaultIOSystem.h>
#include <assimp/importerdesc.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <algorithm>
#include <assimp/Importer.hpp>
#include <cmath>
#include <filesystem>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "codec/image_files.h"

namespace skimap::sim {
namespace {

namespace fs = std::filesystem;

bool InsideFolder(const fs::path& file, const fs::path& dir) {
  std::error_code ec;
  const fs::path canonical = fs::weakly_canonical(file, ec);
  const fs::path root = fs::weakly_canonical(dir.empty() ? "." : dir, ec);
  const fs::path inside = canonical.lexically_relative(root);
  return !ec && !inside.empty() && *inside.begin() != "..";
}

// Assimp's file access limited to the model's folder: an OBJ's mtllib or a glTF's buffer
// uri that names a file elsewhere is not opened.
class FolderIOSystem : public Assimp::DefaultIOSystem {
 public:
  explicit FolderIOSystem(fs::path dir) : dir_(std::move(dir)) {}
  bool Exists(const char* file) const override {
    return InsideFolder(file, dir_) && DefaultIOSystem::Exists(file);
  }
  Assimp::IOStream* Open(const char* file, const char* mode) override {
    if (!InsideFolder(file, dir_) ||
        std::string_view(mode).find_first_of("wa+") != std::string_view::npos) {
      return nullptr;
    }
    return DefaultIOSystem::Open(file, mode);
  }

 private:
  fs::path dir_;
};

// Drops (and deletes: Assimp does not) every importer that reads none of kModelFormats.
void KeepOnlyOurFormats(Assimp::Importer& importer) {
  std::vector<Assimp::BaseImporter*> others;
  for (size_t i = 0; i < importer.GetImporterCount(); ++i) {
    const aiImporterDesc* info = importer.GetImporterInfo(i);
    bool ours = false;
    for (absl::string_view ext :
         absl::StrSplit(info != nullptr ? info->mFileExtensions : "", ' ', absl::SkipEmpty())) {
      for (const char* format : kModelFormats) ours = ours || ext == format;
    }
    if (!ours) others.push_back(importer.GetImporter(i));
  }
  for (Assimp::BaseImporter* other : others) {
    if (importer.UnregisterLoader(other) == AI_SUCCESS) delete other;
  }
}

// The texture as decoded (no OpenCV processing here: its thread pool is not for a forked
// child); nullptr when it is empty or over what is left of `budget` bytes.
Texture Raw(cv::Mat image, size_t* budget) {
  if (image.empty()) return nullptr;
  const size_t bytes = image.total() * image.elemSize();
  if (bytes > *budget) return nullptr;
  *budget -= bytes;
  return std::make_shared<const cv::Mat>(std::move(image));
}

// The material's colour texture: embedded ("*0", or by name in glTF) or a file under the
// model's folder (a path that leaves it is not read). nullptr when it has none or it
// cannot be read.
Texture MaterialTexture(const aiScene& scene, const aiMaterial& material, const fs::path& dir,
                        size_t* budget) {
  aiString name;
  bool found = false;
  for (aiTextureType type : {aiTextureType_BASE_COLOR, aiTextureType_DIFFUSE}) {
    if (material.GetTextureCount(type) > 0 && material.GetTexture(type, 0, &name) == AI_SUCCESS) {
      found = true;
      break;
    }
  }
  if (!found) return nullptr;
  if (const aiTexture* embedded = scene.GetEmbeddedTexture(name.C_Str())) {
    if (embedded->mHeight == 0) {  // compressed (PNG, JPEG): mWidth bytes
      const std::string_view bytes(reinterpret_cast<const char*>(embedded->pcData),
                                   embedded->mWidth);
      return Raw(perception::DecodeImage(bytes, perception::ImageMode::kColor).value_or(cv::Mat()),
                 budget);
    }
    // Raw BGRA texels.
    cv::Mat bgra(int(embedded->mHeight), int(embedded->mWidth), CV_8UC4,
                 const_cast<aiTexel*>(embedded->pcData));
    return Raw(bgra.clone(), budget);
  }
  const fs::path file = dir / name.C_Str();
  if (!InsideFolder(file, dir)) return nullptr;
  return Raw(
      perception::ReadImageFile(file.string(), perception::ImageMode::kColor).value_or(cv::Mat()),
      budget);
}

// The material's diffuse colour as a one-texel texture (white when it has none).
Texture MaterialColour(const aiMaterial& material) {
  aiColor4D c(1, 1, 1, 1);
  material.Get(AI_MATKEY_COLOR_DIFFUSE, c);
  auto channel = [](float v) { return uint8_t(std::clamp(v, 0.f, 1.f) * 255.f + 0.5f); };
  return FlatTexture(channel(c.b), channel(c.g), channel(c.r));
}

// Appends `mesh` to `out`: textured when it has a texture and coordinates, else coloured
// per vertex (a palette texture of one texel per triangle), else in its material's colour.
void AppendMesh(const aiScene& scene, const aiMesh& mesh, const fs::path& dir, size_t* budget,
                Mesh* out) {
  const aiMaterial& material = *scene.mMaterials[mesh.mMaterialIndex];
  const Texture texture =
      mesh.HasTextureCoords(0) ? MaterialTexture(scene, material, dir, budget) : nullptr;
  std::vector<const aiFace*> faces;
  for (unsigned f = 0; f < mesh.mNumFaces; ++f) {
    if (mesh.mFaces[f].mNumIndices == 3) faces.push_back(&mesh.mFaces[f]);
  }
  if (faces.empty()) return;
  auto position = [&](unsigned v) {
    const aiVector3D& p = mesh.mVertices[v];
    return Eigen::Vector3f(p.x, p.y, p.z);
  };
  const int texture_index = int(out->textures.size());
  if (texture != nullptr || !mesh.HasVertexColors(0)) {
    out->textures.push_back(texture != nullptr ? texture : MaterialColour(material));
    const int base = int(out->positions.size());
    for (unsigned v = 0; v < mesh.mNumVertices; ++v) {
      out->positions.push_back(position(v));
      Eigen::Vector2f uv(0.5f, 0.5f);
      if (texture != nullptr) {
        const aiVector3D& t = mesh.mTextureCoords[0][v];
        uv = Eigen::Vector2f(t.x, 1.f - t.y);  // Assimp's v points up; the image's down
      }
      out->uvs.push_back(uv);
    }
    for (const aiFace* f : faces) {
      out->triangles.push_back(
          {base + int(f->mIndices[0]), base + int(f->mIndices[1]), base + int(f->mIndices[2])});
      out->tri_texture.push_back(texture_index);
    }
    return;
  }
  // Vertex colours: each triangle one texel of a palette, its vertices split off.
  const int n = int(faces.size());
  const int width = std::min(n, 1024), height = (n + width - 1) / width;
  cv::Mat palette(height, width, CV_8UC3, cv::Scalar::all(0));
  for (int i = 0; i < n; ++i) {
    aiColor4D sum(0, 0, 0, 0);
    for (int k = 0; k < 3; ++k) sum = sum + mesh.mColors[0][faces[i]->mIndices[k]];
    auto channel = [](float v) { return uint8_t(std::clamp(v / 3.f, 0.f, 1.f) * 255.f + 0.5f); };
    palette.at<cv::Vec3b>(i / width, i % width) =
        cv::Vec3b(channel(sum.b), channel(sum.g), channel(sum.r));
    const Eigen::Vector2f uv((i % width + 0.5f) / width, (i / width + 0.5f) / height);
    const int base = int(out->positions.size());
    for (int k = 0; k < 3; ++k) {
      out->positions.push_back(position(faces[i]->mIndices[k]));
      out->uvs.push_back(uv);
    }
    out->triangles.push_back({base, base + 1, base + 2});
    out->tri_texture.push_back(texture_index);
  }
  out->textures.push_back(std::make_shared<const cv::Mat>(std::move(palette)));
}

}  // namespace

absl::StatusOr<Mesh> ReadModelWithAssimp(const std::string& path, size_t max_triangles,
                                         size_t texture_budget) {
  Assimp::Importer importer;
  KeepOnlyOurFormats(importer);
  importer.SetIOHandler(new FolderIOSystem(fs::path(path).parent_path()));  // owned by it
  // Points and lines are dropped; node transforms are baked in (one model frame).
  importer.SetPropertyInteger(AI_CONFIG_PP_SBP_REMOVE,
                              aiPrimitiveType_POINT | aiPrimitiveType_LINE);
  const aiScene* scene =
      importer.ReadFile(path, aiProcess_Triangulate | aiProcess_PreTransformVertices |
                                  aiProcess_SortByPType | aiProcess_ValidateDataStructure);
  if (scene == nullptr || (scene->mFlags & AI_SCENE_FLAGS_INCOMPLETE)) {
    return absl::InvalidArgumentError(
        absl::StrCat(path, ": not a readable model: ", importer.GetErrorString()));
  }
  size_t triangles = 0;
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) triangles += scene->mMeshes[m]->mNumFaces;
  if (triangles > max_triangles) {
    return absl::InvalidArgumentError(absl::StrCat(
        path, ": ", triangles, " triangles; a model of at most ", max_triangles, " is read"));
  }
  Mesh mesh;
  const fs::path dir = fs::path(path).parent_path();
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
    AppendMesh(*scene, *scene->mMeshes[m], dir, &texture_budget, &mesh);
  }
  if (mesh.triangles.empty()) {
    return absl::InvalidArgumentError(absl::StrCat(path, ": the model has no triangle"));
  }
  return mesh;
}

}  // namespace skimap::sim
