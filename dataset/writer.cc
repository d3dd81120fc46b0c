// BOP + TUM writer. See writer.h for the contract.
#include "dataset/writer.h"

#include <cstdio>
#include <filesystem>
#include <string>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "dataset/json_util.h"

namespace skimap::dataset {
namespace {

namespace fs = std::filesystem;
using internal::FormatDouble;

std::string Numbers(std::initializer_list<double> v) {
  std::string s = "[";
  for (double x : v) absl::StrAppend(&s, s.size() > 1 ? ", " : "", FormatDouble(x));
  return s + "]";
}

std::string Ints(const std::array<int, 4>& v) {
  return absl::StrCat("[", absl::StrJoin(v, ", "), "]");
}

std::string RotationJson(const Eigen::Matrix3d& R) {
  return Numbers({R(0, 0), R(0, 1), R(0, 2), R(1, 0), R(1, 1), R(1, 2), R(2, 0), R(2, 1), R(2, 2)});
}

std::string TranslationMmJson(const Eigen::Vector3d& t) {
  return Numbers({t.x() * 1e3, t.y() * 1e3, t.z() * 1e3});
}

std::string Name(const char* fmt, int a, int b = 0) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), fmt, a, b);
  return buf;
}

// {"<id>": <value>, ...} with one image per line, ids in ascending order.
std::string PerImageJson(const std::map<int, Frame>& frames, std::string (*value)(const Frame& f)) {
  std::string s = "{\n";
  size_t n = 0;
  for (const auto& [id, f] : frames) {
    absl::StrAppend(&s, "  \"", id, "\": ", value(f), ++n < frames.size() ? ",\n" : "\n");
  }
  return s + "}\n";
}

std::string CameraEntry(const Frame& f) {
  const Eigen::Isometry3d T_cw = f.T_wc.inverse();
  return absl::StrCat("{\"cam_K\": ", Numbers({f.K.fx, 0, f.K.cx, 0, f.K.fy, f.K.cy, 0, 0, 1}),
                      ", \"depth_scale\": ", FormatDouble(f.depth_scale),
                      ", \"cam_R_w2c\": ", RotationJson(T_cw.linear()),
                      ", \"cam_t_w2c\": ", TranslationMmJson(T_cw.translation()), "}");
}

std::string GtEntry(const Frame& f) {
  std::vector<std::string> items;
  for (const ObjectAnnotation& a : f.objects) {
    items.push_back(
        absl::StrCat("{\"obj_id\": ", a.obj_id, ", \"cam_R_m2c\": ", RotationJson(a.T_m2c.linear()),
                     ", \"cam_t_m2c\": ", TranslationMmJson(a.T_m2c.translation()), "}"));
  }
  return absl::StrCat("[", absl::StrJoin(items, ", "), "]");
}

std::string GtInfoEntry(const Frame& f) {
  std::vector<std::string> items;
  for (const ObjectAnnotation& a : f.objects) {
    items.push_back(absl::StrCat(
        "{\"bbox_obj\": ", Ints(a.bbox_obj), ", \"bbox_visib\": ", Ints(a.bbox_visib),
        ", \"px_count_all\": ", a.px_count_all, ", \"px_count_valid\": ", a.px_count_valid,
        ", \"px_count_visib\": ", a.px_count_visib,
        ", \"visib_fract\": ", FormatDouble(a.visib_fract), "}"));
  }
  return absl::StrCat("[", absl::StrJoin(items, ", "), "]");
}

std::string Stamp(double t) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.6f", t);
  return buf;
}

}  // namespace

absl::Status WriteBopCamera(const std::string& path, const CameraInfo& c) {
  return internal::WriteTextFile(
      path,
      absl::StrCat("{\n  \"cx\": ", FormatDouble(c.K.cx), ",\n  \"cy\": ", FormatDouble(c.K.cy),
                   ",\n  \"depth_scale\": ", FormatDouble(c.depth_scale),
                   ",\n  \"fx\": ", FormatDouble(c.K.fx), ",\n  \"fy\": ", FormatDouble(c.K.fy),
                   ",\n  \"height\": ", c.K.height, ",\n  \"width\": ", c.K.width, "\n}\n"));
}

absl::Status WriteModelsInfo(const std::string& path, const std::map<int, ModelInfo>& models) {
  std::string s = "{\n";
  size_t n = 0;
  for (const auto& [id, m] : models) {
    const Eigen::Vector3d mn = m.min * 1e3, sz = m.size * 1e3;
    absl::StrAppend(&s, "  \"", id, "\": {\"diameter\": ", FormatDouble(m.diameter * 1e3),
                    ", \"min_x\": ", FormatDouble(mn.x()), ", \"min_y\": ", FormatDouble(mn.y()),
                    ", \"min_z\": ", FormatDouble(mn.z()), ", \"size_x\": ", FormatDouble(sz.x()),
                    ", \"size_y\": ", FormatDouble(sz.y()), ", \"size_z\": ", FormatDouble(sz.z()),
                    "}", ++n < models.size() ? ",\n" : "\n");
  }
  return internal::WriteTextFile(path, s + "}\n");
}

std::string BopRgbPath(const std::string& dir, int id) { return dir + Name("/rgb/%06d.png", id); }
std::string BopDepthPath(const std::string& dir, int id) {
  return dir + Name("/depth/%06d.png", id);
}
std::string BopMaskVisibPath(const std::string& dir, int id, int gt) {
  return dir + Name("/mask_visib/%06d_%06d.png", id, gt);
}

BopSceneWriter::BopSceneWriter(std::string scene_dir) : dir_(std::move(scene_dir)) {}

absl::Status BopSceneWriter::Create() const {
  std::error_code ec;
  for (const char* sub : {"/rgb", "/depth", "/mask_visib"}) {
    fs::create_directories(dir_ + sub, ec);
    if (ec) return absl::InternalError(absl::StrCat(dir_, sub, ": ", ec.message()));
  }
  return absl::OkStatus();
}

void BopSceneWriter::AddFrame(const Frame& frame) { frames_[frame.id] = frame; }

absl::Status BopSceneWriter::Finish() const {
  struct File {
    const char* name;
    std::string text;
  } files[] = {
      {"scene_camera.json", PerImageJson(frames_, CameraEntry)},
      {"scene_gt.json", PerImageJson(frames_, GtEntry)},
      {"scene_gt_info.json", PerImageJson(frames_, GtInfoEntry)},
      {"rgb.txt", "# color images\n# timestamp filename\n"},
      {"depth.txt", "# depth maps (value * depth_scale = mm)\n# timestamp filename\n"},
      {"groundtruth.txt", "# world <- camera, metres\n# timestamp tx ty tz qx qy qz qw\n"}};
  for (const auto& [id, f] : frames_) {
    const std::string t = Stamp(f.timestamp);
    absl::StrAppend(&files[3].text, t, Name(" rgb/%06d.png\n", id));
    absl::StrAppend(&files[4].text, t, Name(" depth/%06d.png\n", id));
    const Eigen::Quaterniond q(f.T_wc.linear());
    const Eigen::Vector3d p = f.T_wc.translation();
    char line[256];
    std::snprintf(line, sizeof(line), " %.6f %.6f %.6f %.9f %.9f %.9f %.9f\n", p.x(), p.y(), p.z(),
                  q.x(), q.y(), q.z(), q.w());
    absl::StrAppend(&files[5].text, t, line);
  }
  for (const File& file : files) {
    if (absl::Status s = internal::WriteTextFile(dir_ + "/" + file.name, file.text); !s.ok()) {
      return s;
    }
  }
  return absl::OkStatus();
}

}  // namespace skimap::dataset
