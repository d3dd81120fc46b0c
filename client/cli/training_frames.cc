#include "client/cli/training_frames.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "client/cli/dataset_frames.h"

namespace skimap::client {
namespace fs = std::filesystem;

absl::StatusOr<std::vector<TrainingObject>> ListTrainingObjects(const std::string& root) {
  const fs::path train = fs::path(root) / "train";
  std::error_code ec;
  if (!fs::is_directory(train, ec)) {
    return absl::NotFoundError(absl::StrCat(root, ": no train/ folder (not a BOP dataset root)"));
  }
  nlohmann::json names;
  if (std::ifstream in(fs::path(root) / "objects.json"); in) {
    names = nlohmann::json::parse(in, nullptr, /*allow_exceptions=*/false);
  }
  std::vector<TrainingObject> out;
  for (const fs::directory_entry& e : fs::directory_iterator(train, ec)) {
    int id = 0;
    if (!e.is_directory() || !absl::SimpleAtoi(e.path().filename().string(), &id)) continue;
    TrainingObject o{id, e.path().string(), ""};
    const std::string key = std::to_string(id);
    if (names.is_object() && names.contains(key) && names[key].is_string()) {
      o.name = names[key].get<std::string>();
    }
    out.push_back(std::move(o));
  }
  std::sort(out.begin(), out.end(),
            [](const TrainingObject& a, const TrainingObject& b) { return a.obj_id < b.obj_id; });
  return out;
}

absl::StatusOr<std::optional<v1::TrainingFrame>> ToTrainingFrame(const dataset::Frame& frame,
                                                                 int obj_id) {
  const dataset::ObjectAnnotation* a = nullptr;
  for (const dataset::ObjectAnnotation& o : frame.objects) {
    if (o.obj_id == obj_id) a = &o;
  }
  if (a == nullptr || a->mask_visib_path.empty() || a->px_count_visib == 0) return std::nullopt;
  // The image part is encoded like a map frame (the camera pose does not matter here).
  dataset::Frame images = frame;
  images.has_pose = true;
  absl::StatusOr<v1::Frame> api = ToApiFrame(images, "", 0, v1::DEPTH_ENCODING_PNG16);
  if (!api.ok()) return api.status();
  std::ifstream in(a->mask_visib_path, std::ios::binary);
  if (!in) return absl::NotFoundError(absl::StrCat("cannot read ", a->mask_visib_path));
  std::ostringstream mask;
  mask << in.rdbuf();
  v1::TrainingFrame out;
  *out.mutable_intrinsics() = api->intrinsics();
  out.set_depth_encoding(api->depth_encoding());
  out.set_depth(std::move(*api->mutable_depth()));
  out.set_depth_scale(api->depth_scale());
  out.set_color_encoding(api->color_encoding());
  out.set_color(std::move(*api->mutable_color()));
  out.set_mask_encoding(v1::MASK_ENCODING_PNG);
  out.set_mask(mask.str());
  ToApiPose(a->T_m2c, out.mutable_object_pose());
  return out;
}

}  // namespace skimap::client
