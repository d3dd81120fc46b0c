#include "dataset/model_points.h"

#include <assimp/scene.h>

#include <algorithm>
#include <assimp/Importer.hpp>
#include <cstdint>
#include <filesystem>
#include <fstream>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"

namespace skimap::dataset {

// A PLY file's header must be whole and its counts possible before Assimp reads it:
// Assimp 5.2 loops forever on a header that ends inside an element line ("element vertex"
// without a number, then EOF), and allocates what a header claims before it reads the body
// (a truncated file claiming 10^6 vertices: 12 MB, leaked when the body runs out). OK for
// another format (Assimp tells them apart) or a header that has a "format" line, numeric
// element counts and "end_header" within 64 KiB, and whose elements fit the bytes after it
// (every property of every element takes at least one byte, ASCII or binary).
absl::Status CheckPlyHeader(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::string line;
  if (!std::getline(in, line) || absl::StripTrailingAsciiWhitespace(line) != "ply") {
    return absl::OkStatus();  // not a PLY file: Assimp's own checks apply
  }
  bool format = false;
  size_t header_bytes = line.size() + 1;
  // Per element: its count and its properties.
  std::vector<std::pair<uint64_t, uint64_t>> elements;
  while (std::getline(in, line) && (header_bytes += line.size() + 1) <= 65536) {
    const absl::string_view l = absl::StripTrailingAsciiWhitespace(line);
    if (l == "end_header") {
      if (!format) break;
      const uint64_t body = std::filesystem::file_size(path) - header_bytes;
      uint64_t least = 0;
      for (const auto& [count, properties] : elements) {
        if (count > body || (least += count * std::max<uint64_t>(properties, 1)) > body) {
          return absl::InvalidArgumentError(absl::StrCat(
              path, ": the PLY header claims more elements than its ", body, " bytes hold"));
        }
      }
      return absl::OkStatus();
    }
    if (absl::StartsWith(l, "format ")) format = true;
    if (absl::StartsWith(l, "property ") && !elements.empty()) ++elements.back().second;
    if (absl::StartsWith(l, "element ")) {
      const std::vector<absl::string_view> words = absl::StrSplit(l, ' ', absl::SkipEmpty());
      uint64_t count = 0;
      if (words.size() != 3 || !absl::SimpleAtoi(words[2], &count)) {
        return absl::InvalidArgumentError(
            absl::StrCat(path, ": PLY header line \"", l, "\" needs a name and a count"));
      }
      elements.emplace_back(count, 0);
    }
  }
  return absl::InvalidArgumentError(
      absl::StrCat(path, ": PLY header without a format line or end_header (within 64 KiB)"));
}

absl::StatusOr<std::vector<Eigen::Vector3d>> LoadModelPoints(const std::string& path, double scale,
                                                             int max_points) {
  if (!std::filesystem::is_regular_file(path)) {
    return absl::NotFoundError(absl::StrCat(path, ": no such model file"));
  }
  if (absl::Status s = CheckPlyHeader(path); !s.ok()) return s;
  Assimp::Importer importer;
  // No post-processing: the file's vertices as they are (no welding, no normals).
  const aiScene* scene = importer.ReadFile(path, 0);
  if (scene == nullptr) {
    return absl::InvalidArgumentError(
        absl::StrCat(path, ": not a readable model: ", importer.GetErrorString()));
  }
  size_t total = 0;
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) total += scene->mMeshes[m]->mNumVertices;
  if (total == 0)
    return absl::InvalidArgumentError(absl::StrCat(path, ": the model has no vertex"));
  const size_t step = max_points > 0 && total > static_cast<size_t>(max_points)
                          ? (total + max_points - 1) / max_points
                          : 1;
  std::vector<Eigen::Vector3d> points;
  points.reserve(total / step + 1);
  size_t index = 0;
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
    const aiMesh& mesh = *scene->mMeshes[m];
    for (unsigned v = 0; v < mesh.mNumVertices; ++v, ++index) {
      if (index % step != 0) continue;
      const aiVector3D& p = mesh.mVertices[v];
      points.emplace_back(p.x * scale, p.y * scale, p.z * scale);
    }
  }
  return points;
}

}  // namespace skimap::dataset
