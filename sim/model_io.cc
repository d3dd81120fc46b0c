// Assimp scenes into Meshes. See model_io.h for the contract.
#include "sim/model_io.h"

#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <algorithm>
#include <assimp/Importer.hpp>
#include <cmath>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "absl/strings/str_cat.h"
#include "dataset/model_points.h"

namespace skimap::sim {
namespace {

namespace fs = std::filesystem;

// A BGR texture no larger than `side` on its longer side; empty when `image` is.
Texture Fit(cv::Mat image, int side) {
  if (image.empty()) return nullptr;
  if (image.channels() == 4) cv::cvtColor(image, image, cv::COLOR_BGRA2BGR);
  if (image.channels() == 1) cv::cvtColor(image, image, cv::COLOR_GRAY2BGR);
  if (image.depth() != CV_8U) image.convertTo(image, CV_8U, 1.0 / 257);
  const int longer = std::max(image.cols, image.rows);
  if (longer > side) {
    const double f = double(side) / longer;
    cv::resize(image, image, cv::Size(), f, f, cv::INTER_AREA);
  }
  return std::make_shared<const cv::Mat>(std::move(image));
}

// The material's colour texture: embedded ("*0", or by name in glTF) or a file under the
// model's folder (a path that leaves it is not read). nullptr when it has none or it
// cannot be read.
Texture MaterialTexture(const aiScene& scene, const aiMaterial& material, const fs::path& dir,
                        int side) {
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
      const cv::Mat bytes(1, int(embedded->mWidth), CV_8UC1,
                          const_cast<aiTexel*>(embedded->pcData));
      return Fit(cv::imdecode(bytes, cv::IMREAD_COLOR), side);
    }
    // Raw BGRA texels.
    cv::Mat bgra(int(embedded->mHeight), int(embedded->mWidth), CV_8UC4,
                 const_cast<aiTexel*>(embedded->pcData));
    return Fit(bgra.clone(), side);
  }
  std::error_code ec;
  const fs::path file = fs::weakly_canonical(dir / name.C_Str(), ec);
  const fs::path root = fs::weakly_canonical(dir.empty() ? "." : dir, ec);
  const fs::path inside = file.lexically_relative(root);
  if (ec || inside.empty() || *inside.begin() == "..") return nullptr;  // outside the folder
  return Fit(cv::imread(file.string(), cv::IMREAD_COLOR), side);
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
void AppendMesh(const aiScene& scene, const aiMesh& mesh, const fs::path& dir, int side,
                Mesh* out) {
  const aiMaterial& material = *scene.mMaterials[mesh.mMaterialIndex];
  const Texture texture =
      mesh.HasTextureCoords(0) ? MaterialTexture(scene, material, dir, side) : nullptr;
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

absl::StatusOr<ModelUnits> ParseModelUnits(const std::string& text, const std::string& flag) {
  if (text == "auto") return ModelUnits::kAuto;
  if (text == "m") return ModelUnits::kMetres;
  if (text == "mm") return ModelUnits::kMillimetres;
  return absl::InvalidArgumentError(
      absl::StrCat(flag, ": '", text, "' is not auto, m (metres) or mm (millimetres)"));
}

absl::StatusOr<Mesh> LoadModel(const std::string& path, const ModelOptions& options) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) {
    return absl::NotFoundError(absl::StrCat(path, ": no such model file"));
  }
  if (const uintmax_t bytes = fs::file_size(path, ec); ec || bytes > options.max_file_bytes) {
    return absl::InvalidArgumentError(absl::StrCat(path, ": a model file of at most ",
                                                   options.max_file_bytes >> 20, " MiB is read"));
  }
  if (absl::Status s = dataset::CheckPlyHeader(path); !s.ok()) return s;
  Assimp::Importer importer;
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
  if (triangles > options.max_triangles) {
    return absl::InvalidArgumentError(absl::StrCat(path, ": ", triangles,
                                                   " triangles; a model of at most ",
                                                   options.max_triangles, " is read"));
  }
  Mesh mesh;
  const fs::path dir = fs::path(path).parent_path();
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
    AppendMesh(*scene, *scene->mMeshes[m], dir, options.max_texture_side, &mesh);
  }
  if (mesh.triangles.empty()) {
    return absl::InvalidArgumentError(absl::StrCat(path, ": the model has no triangle"));
  }
  for (const Eigen::Vector3f& p : mesh.positions) {
    if (!p.allFinite()) {
      return absl::InvalidArgumentError(absl::StrCat(path, ": a vertex is not a finite number"));
    }
  }
  float scale = options.units == ModelUnits::kMillimetres ? 0.001f : 1.f;
  if (options.units == ModelUnits::kAuto && mesh.Bounds().diagonal().norm() > 10.f) scale = 0.001f;
  if (scale != 1.f) {
    for (Eigen::Vector3f& p : mesh.positions) p *= scale;
  }
  return mesh;
}

}  // namespace skimap::sim
