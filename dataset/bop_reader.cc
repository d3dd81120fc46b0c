// BOP reader: camera.json, models_info.json, scene folders. See reader.h for the contract.
#include <algorithm>
#include <cstdio>
#include <filesystem>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "codec/image_files.h"
#include "dataset/json_util.h"
#include "dataset/reader.h"

namespace skimap::dataset {
namespace {

namespace fs = std::filesystem;
using internal::GetNumber;
using internal::GetNumbers;
using internal::ReadJsonFile;

std::string ImageName(int id, const char* ext) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%06d%s", id, ext);
  return buf;
}

std::string MaskName(int id, int gt) {
  char buf[48];
  std::snprintf(buf, sizeof(buf), "%06d_%06d.png", id, gt);
  return buf;
}

// R (row-major 3x3) and t (mm) -> isometry in metres.
Eigen::Isometry3d PoseFromBop(const std::vector<double>& r, const std::vector<double>& t_mm) {
  Eigen::Matrix3d R;
  R << r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7], r[8];
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = R;
  T.translation() = Eigen::Vector3d(t_mm[0], t_mm[1], t_mm[2]) * 1e-3;
  return T;
}

// Parses a JSON object keyed by decimal ids into sorted (id, value) pairs.
absl::StatusOr<std::vector<std::pair<int, const nlohmann::json*>>> IdEntries(
    const nlohmann::json& j, const std::string& file) {
  if (!j.is_object()) return absl::InvalidArgumentError(absl::StrCat(file, ": not an object"));
  std::vector<std::pair<int, const nlohmann::json*>> out;
  for (auto it = j.begin(); it != j.end(); ++it) {
    int id = 0;
    if (!absl::SimpleAtoi(it.key(), &id)) {
      return absl::InvalidArgumentError(
          absl::StrCat(file, ": key \"", it.key(), "\" is not an integer id"));
    }
    out.emplace_back(id, &it.value());
  }
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  return out;
}

absl::Status ReadGt(const std::string& scene_dir, std::map<int, Frame*>& by_id) {
  const std::string gt_path = scene_dir + "/scene_gt.json";
  if (!fs::exists(gt_path)) return absl::OkStatus();
  absl::StatusOr<nlohmann::json> gt = ReadJsonFile(gt_path);
  if (!gt.ok()) return gt.status();
  auto entries = IdEntries(*gt, gt_path);
  if (!entries.ok()) return entries.status();
  for (const auto& [id, list] : *entries) {
    auto it = by_id.find(id);
    if (it == by_id.end()) {
      return absl::InvalidArgumentError(
          absl::StrCat(gt_path, ": image ", id, " is not in scene_camera.json"));
    }
    if (!list->is_array()) {
      return absl::InvalidArgumentError(absl::StrCat(gt_path, ": [", id, "]: not an array"));
    }
    for (size_t g = 0; g < list->size(); ++g) {
      const std::string where = absl::StrCat("[", id, "][", g, "]");
      const nlohmann::json& e = (*list)[g];
      auto obj_id = GetNumber(e, "obj_id", gt_path, where);
      auto r = GetNumbers(e, "cam_R_m2c", 9, gt_path, where);
      auto t = GetNumbers(e, "cam_t_m2c", 3, gt_path, where);
      if (!obj_id.ok()) return obj_id.status();
      if (!r.ok()) return r.status();
      if (!t.ok()) return t.status();
      ObjectAnnotation a;
      a.obj_id = static_cast<int>(*obj_id);
      a.T_m2c = PoseFromBop(*r, *t);
      const std::string mask = scene_dir + "/mask_visib/" + MaskName(id, static_cast<int>(g));
      if (fs::exists(mask)) a.mask_visib_path = mask;
      it->second->objects.push_back(a);
    }
  }
  return absl::OkStatus();
}

absl::Status ReadGtInfo(const std::string& scene_dir, std::map<int, Frame*>& by_id) {
  const std::string path = scene_dir + "/scene_gt_info.json";
  if (!fs::exists(path)) return absl::OkStatus();
  absl::StatusOr<nlohmann::json> info = ReadJsonFile(path);
  if (!info.ok()) return info.status();
  auto entries = IdEntries(*info, path);
  if (!entries.ok()) return entries.status();
  for (const auto& [id, list] : *entries) {
    auto it = by_id.find(id);
    if (it == by_id.end() || !list->is_array() || list->size() != it->second->objects.size()) {
      return absl::InvalidArgumentError(
          absl::StrCat(path, ": [", id, "]: entries do not match scene_gt.json"));
    }
    for (size_t g = 0; g < list->size(); ++g) {
      const nlohmann::json& e = (*list)[g];
      ObjectAnnotation& a = it->second->objects[g];
      const std::string where = absl::StrCat("[", id, "][", g, "]");
      if (e.contains("bbox_visib")) {
        auto bb = GetNumbers(e, "bbox_visib", 4, path, where);
        if (!bb.ok()) return bb.status();
        for (int k = 0; k < 4; ++k) a.bbox_visib[k] = static_cast<int>((*bb)[k]);
      }
      if (e.contains("bbox_obj")) {
        auto bb = GetNumbers(e, "bbox_obj", 4, path, where);
        if (!bb.ok()) return bb.status();
        for (int k = 0; k < 4; ++k) a.bbox_obj[k] = static_cast<int>((*bb)[k]);
      }
      if (e.contains("px_count_all")) a.px_count_all = *GetNumber(e, "px_count_all", path, where);
      if (e.contains("px_count_visib"))
        a.px_count_visib = *GetNumber(e, "px_count_visib", path, where);
      if (e.contains("px_count_valid"))
        a.px_count_valid = *GetNumber(e, "px_count_valid", path, where);
      if (e.contains("visib_fract")) a.visib_fract = *GetNumber(e, "visib_fract", path, where);
    }
  }
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<CameraInfo> LoadBopCamera(const std::string& path) {
  absl::StatusOr<nlohmann::json> j = ReadJsonFile(path);
  if (!j.ok()) return j.status();
  CameraInfo cam;
  const char* keys[] = {"fx", "fy", "cx", "cy", "width", "height", "depth_scale"};
  double v[7];
  for (int i = 0; i < 7; ++i) {
    auto n = GetNumber(*j, keys[i], path, "camera");
    if (!n.ok()) return n.status();
    v[i] = *n;
  }
  cam.K = {v[0], v[1], v[2], v[3], static_cast<int>(v[4]), static_cast<int>(v[5])};
  cam.depth_scale = v[6];
  if (cam.K.width <= 0 || cam.K.height <= 0 || cam.K.fx <= 0 || cam.K.fy <= 0 ||
      cam.depth_scale <= 0) {
    return absl::InvalidArgumentError(absl::StrCat(path, ": non-positive size, focal or scale"));
  }
  return cam;
}

absl::StatusOr<std::map<int, ModelInfo>> LoadModelsInfo(const std::string& path) {
  absl::StatusOr<nlohmann::json> j = ReadJsonFile(path);
  if (!j.ok()) return j.status();
  auto entries = IdEntries(*j, path);
  if (!entries.ok()) return entries.status();
  const std::string dir = fs::path(path).parent_path().string();
  std::map<int, ModelInfo> out;
  for (const auto& [id, e] : *entries) {
    const std::string where = absl::StrCat("[", id, "]");
    ModelInfo m;
    m.obj_id = id;
    const char* keys[] = {"diameter", "min_x", "min_y", "min_z", "size_x", "size_y", "size_z"};
    double v[7];
    for (int i = 0; i < 7; ++i) {
      auto n = GetNumber(*e, keys[i], path, where);
      if (!n.ok()) return n.status();
      v[i] = *n * 1e-3;
    }
    m.diameter = v[0];
    m.min = {v[1], v[2], v[3]};
    m.size = {v[4], v[5], v[6]};
    if (e->contains("symmetries_discrete")) {
      const nlohmann::json& list = (*e)["symmetries_discrete"];
      if (!list.is_array()) {
        return absl::InvalidArgumentError(
            absl::StrCat(path, ": ", where, ".symmetries_discrete: not an array"));
      }
      for (size_t k = 0; k < list.size(); ++k) {
        nlohmann::json holder = {{"m", list[k]}};
        auto m16 =
            GetNumbers(holder, "m", 16, path, absl::StrCat(where, ".symmetries_discrete[", k, "]"));
        if (!m16.ok()) return m16.status();
        Eigen::Isometry3d S = Eigen::Isometry3d::Identity();
        for (int r = 0; r < 3; ++r) {
          for (int c = 0; c < 3; ++c) S.linear()(r, c) = (*m16)[r * 4 + c];
          S.translation()[r] = (*m16)[r * 4 + 3] * 1e-3;
        }
        m.symmetries.push_back(S);
      }
    }
    if (e->contains("symmetries_continuous")) {
      const nlohmann::json& list = (*e)["symmetries_continuous"];
      if (!list.is_array()) {
        return absl::InvalidArgumentError(
            absl::StrCat(path, ": ", where, ".symmetries_continuous: not an array"));
      }
      for (size_t k = 0; k < list.size(); ++k) {
        const std::string at = absl::StrCat(where, ".symmetries_continuous[", k, "]");
        auto axis = GetNumbers(list[k], "axis", 3, path, at);
        if (!axis.ok()) return axis.status();
        auto offset = GetNumbers(list[k], "offset", 3, path, at);
        if (!offset.ok()) return offset.status();
        const Eigen::Vector3d a((*axis)[0], (*axis)[1], (*axis)[2]);
        if (a.norm() < 1e-9) {
          return absl::InvalidArgumentError(absl::StrCat(path, ": ", at, ".axis: zero vector"));
        }
        const Eigen::Vector3d o = Eigen::Vector3d((*offset)[0], (*offset)[1], (*offset)[2]) * 1e-3;
        for (double deg = kContinuousSymmetryStepDeg; deg < 360;
             deg += kContinuousSymmetryStepDeg) {
          // A turn about the axis through `offset`: x -> R (x - o) + o.
          Eigen::Isometry3d S = Eigen::Isometry3d::Identity();
          S.linear() = Eigen::AngleAxisd(deg * M_PI / 180, a.normalized()).toRotationMatrix();
          S.translation() = o - S.linear() * o;
          m.symmetries.push_back(S);
        }
      }
    }
    char name[32];
    std::snprintf(name, sizeof(name), "obj_%06d.ply", id);
    const std::string ply = (dir.empty() ? std::string(".") : dir) + "/" + name;
    if (fs::exists(ply)) m.ply_path = ply;
    out[id] = m;
  }
  return out;
}

absl::StatusOr<Sequence> LoadBopScene(const std::string& scene_dir,
                                      const BopSceneOptions& options) {
  const std::string cam_path = scene_dir + "/scene_camera.json";
  absl::StatusOr<nlohmann::json> cams = ReadJsonFile(cam_path);
  if (!cams.ok()) return cams.status();
  auto entries = IdEntries(*cams, cam_path);
  if (!entries.ok()) return entries.status();

  std::optional<CameraInfo> camera = options.camera;
  fs::path dir(scene_dir);
  if (!dir.has_filename()) dir = dir.parent_path();  // tolerate a trailing '/'
  for (const fs::path& p : {dir.parent_path(), dir.parent_path().parent_path()}) {
    if (camera || p.empty() || !fs::exists(p / "camera.json")) continue;
    auto c = LoadBopCamera((p / "camera.json").string());
    if (!c.ok()) return c.status();
    camera = *c;
  }

  Sequence seq;
  seq.dir = scene_dir;
  for (const auto& [id, e] : *entries) {
    const std::string where = absl::StrCat("[", id, "]");
    Frame f;
    f.id = id;
    f.timestamp = id / options.fps;
    auto k = GetNumbers(*e, "cam_K", 9, cam_path, where);
    if (!k.ok()) return k.status();
    f.K = {(*k)[0], (*k)[4], (*k)[2], (*k)[5], 0, 0};
    if (camera) {
      f.K.width = camera->K.width;
      f.K.height = camera->K.height;
    }
    f.depth_scale = camera ? camera->depth_scale : 1.0;
    if (e->contains("depth_scale")) {
      auto s = GetNumber(*e, "depth_scale", cam_path, where);
      if (!s.ok()) return s.status();
      f.depth_scale = *s;
    }
    if (e->contains("cam_R_w2c") || e->contains("cam_t_w2c")) {
      auto r = GetNumbers(*e, "cam_R_w2c", 9, cam_path, where);
      auto t = GetNumbers(*e, "cam_t_w2c", 3, cam_path, where);
      if (!r.ok()) return r.status();
      if (!t.ok()) return t.status();
      f.T_wc = PoseFromBop(*r, *t).inverse();
      f.has_pose = true;
    }
    const std::string png = scene_dir + "/rgb/" + ImageName(id, ".png");
    const std::string jpg = scene_dir + "/rgb/" + ImageName(id, ".jpg");
    f.rgb_path = fs::exists(png) || !fs::exists(jpg) ? png : jpg;
    const std::string depth = scene_dir + "/depth/" + ImageName(id, ".png");
    if (fs::exists(depth)) f.depth_path = depth;
    seq.frames.push_back(std::move(f));
  }
  if (seq.frames.empty()) {
    return absl::InvalidArgumentError(absl::StrCat(cam_path, ": no images"));
  }
  if (!camera) {  // image size from the first rgb image header
    const cv::Mat first =
        perception::ReadImageFile(seq.frames[0].rgb_path, perception::ImageMode::kUnchanged)
            .value_or(cv::Mat());
    if (first.empty()) {
      return absl::NotFoundError(absl::StrCat(seq.frames[0].rgb_path, ": cannot read image"));
    }
    for (Frame& f : seq.frames) {
      f.K.width = first.cols;
      f.K.height = first.rows;
    }
  }
  std::map<int, Frame*> by_id;
  for (Frame& f : seq.frames) by_id[f.id] = &f;
  if (absl::Status s = ReadGt(scene_dir, by_id); !s.ok()) return s;
  if (absl::Status s = ReadGtInfo(scene_dir, by_id); !s.ok()) return s;
  return seq;
}

absl::StatusOr<BopDataset> LoadBopDataset(const std::string& root) {
  if (!fs::is_directory(root)) return absl::NotFoundError(absl::StrCat(root, ": no such folder"));
  BopDataset ds;
  ds.root = root;
  if (fs::exists(root + "/camera.json")) {
    auto c = LoadBopCamera(root + "/camera.json");
    if (!c.ok()) return c.status();
    ds.camera = *c;
  }
  for (const char* p : {"/models_info.json", "/models/models_info.json"}) {
    if (fs::exists(root + p)) {
      auto m = LoadModelsInfo(root + p);
      if (!m.ok()) return m.status();
      ds.models = std::move(*m);
      break;
    }
  }
  std::error_code ec;
  for (const auto& split : fs::directory_iterator(root, ec)) {
    if (!split.is_directory()) continue;
    std::vector<std::string> scenes;
    for (const auto& s : fs::directory_iterator(split.path(), ec)) {
      if (s.is_directory() && fs::exists(s.path() / "scene_camera.json")) {
        scenes.push_back(s.path().string());
      }
    }
    std::sort(scenes.begin(), scenes.end());
    if (!scenes.empty()) ds.scenes[split.path().filename().string()] = std::move(scenes);
  }
  return ds;
}

}  // namespace skimap::dataset
