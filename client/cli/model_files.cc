// A model's companion files. See model_files.h for the contract.
#include "client/cli/model_files.h"

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"

namespace skimap::client {
namespace {
namespace fs = std::filesystem;

// Lines of `path` that start with one of `keys`: the rest of each line (its last field for
// map_* lines, whose options come before the file name).
std::vector<std::string> Referenced(const fs::path& path, const std::vector<std::string>& keys,
                                    bool last_field) {
  std::vector<std::string> out;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    const std::string trimmed(absl::StripAsciiWhitespace(line));
    for (const std::string& key : keys) {
      if (!absl::StartsWith(trimmed, key + " ") && !absl::StartsWith(trimmed, key + "\t")) {
        continue;
      }
      const std::string rest(absl::StripAsciiWhitespace(trimmed.substr(key.size())));
      if (!last_field) {
        for (absl::string_view name : absl::StrSplit(rest, ' ', absl::SkipEmpty())) {
          out.emplace_back(name);
        }
      } else {
        std::vector<std::string> fields = absl::StrSplit(rest, ' ', absl::SkipEmpty());
        if (!fields.empty()) out.push_back(fields.back());
      }
    }
  }
  return out;
}

std::vector<std::string> GltfUris(const fs::path& path) {
  std::vector<std::string> out;
  std::ifstream in(path);
  const nlohmann::json j = nlohmann::json::parse(in, nullptr, /*allow_exceptions=*/false);
  if (!j.is_object()) return out;
  for (const char* list : {"buffers", "images"}) {
    if (!j.contains(list) || !j[list].is_array()) continue;
    for (const nlohmann::json& item : j[list]) {
      if (item.is_object() && item.contains("uri") && item["uri"].is_string()) {
        const std::string uri = item["uri"];
        if (!absl::StartsWith(uri, "data:")) out.push_back(uri);
      }
    }
  }
  return out;
}

}  // namespace

absl::StatusOr<ModelFileSet> ModelFiles(const std::string& model) {
  std::error_code ec;
  if (!fs::is_regular_file(model, ec)) {
    return absl::NotFoundError(absl::StrCat(model, ": no such model file"));
  }
  const fs::path dir = fs::path(model).parent_path();
  const fs::path root = fs::weakly_canonical(dir.empty() ? "." : dir, ec);
  ModelFileSet set;
  set.files.push_back({fs::path(model).filename().string(), model});
  std::set<std::string> seen = {set.files[0].name};
  // Adds `name` (relative to the model's folder) once; returns its local path or "".
  auto add = [&](const std::string& name) -> fs::path {
    const fs::path local = fs::weakly_canonical(dir / name, ec);
    const fs::path inside = local.lexically_relative(root);
    if (ec || inside.empty() || *inside.begin() == ".." || !fs::is_regular_file(local, ec)) {
      set.skipped.push_back(name);
      return {};
    }
    const std::string upload = inside.generic_string();
    if (seen.insert(upload).second) set.files.push_back({upload, local.string()});
    return local;
  };
  const std::string ext = absl::AsciiStrToLower(fs::path(model).extension().string());
  if (ext == ".obj") {
    for (const std::string& mtl : Referenced(model, {"mtllib"}, false)) {
      const fs::path local = add(mtl);
      if (local.empty()) continue;
      for (const std::string& image :
           Referenced(local, {"map_Kd", "map_Ka", "map_Ks", "map_d", "map_bump", "bump"}, true)) {
        // A map in the MTL is relative to the MTL's folder.
        add((fs::path(mtl).parent_path() / image).lexically_normal().generic_string());
      }
    }
  } else if (ext == ".gltf") {
    for (const std::string& uri : GltfUris(model)) add(uri);
  }
  return set;
}

}  // namespace skimap::client
