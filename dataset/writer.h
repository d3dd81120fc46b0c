// Writer for BOP datasets (plus TUM text files), the inverse of reader.h: what it writes,
// LoadBopScene / LoadTumSequence read back to the same values (poses to ~1e-12 relative,
// JSON numbers are written with round-trip precision).
//
// Layout written for one scene folder:
//   scene_camera.json  {"<id>": {cam_K, depth_scale, cam_R_w2c, cam_t_w2c (mm)}}
//   scene_gt.json      {"<id>": [{obj_id, cam_R_m2c, cam_t_m2c (mm)}, ...]}
//   scene_gt_info.json {"<id>": [{bbox_obj, bbox_visib, px_count_all, px_count_valid,
//                                 px_count_visib, visib_fract}, ...]}  (same order)
//   rgb.txt, depth.txt, groundtruth.txt   TUM lines "t path" / "t tx ty tz qx qy qz qw"
//                                         (world <- camera, metres), paths relative
// Images (rgb/IIIIII.png, depth/IIIIII.png, mask_visib/IIIIII_GGGGGG.png) are written by
// the caller at the paths this class hands out.
//
// Thread safety: free functions are reentrant. BopSceneWriter is not thread safe; callers
// that render frames in parallel add them from one thread (any order: ids are sorted).
#ifndef SKIMAP_DATASET_WRITER_H_
#define SKIMAP_DATASET_WRITER_H_

#include <map>
#include <string>

#include "absl/status/status.h"
#include "dataset/types.h"

namespace skimap::dataset {

// Writes a BOP camera.json (fx, fy, cx, cy, width, height, depth_scale).
[[nodiscard]] absl::Status WriteBopCamera(const std::string& path, const CameraInfo& camera);

// Writes a BOP models_info.json (diameter, min_*, size_* in millimetres).
[[nodiscard]] absl::Status WriteModelsInfo(const std::string& path,
                                           const std::map<int, ModelInfo>& models);

// "<dir>/rgb/000012.png" style paths of a BOP scene folder.
std::string BopRgbPath(const std::string& scene_dir, int image_id);
std::string BopDepthPath(const std::string& scene_dir, int image_id);
std::string BopMaskVisibPath(const std::string& scene_dir, int image_id, int gt_index);

// Collects the frames of one scene and writes its JSON and TUM text files.
class BopSceneWriter {
 public:
  // scene_dir need not exist yet; Create() makes it with rgb/, depth/, mask_visib/.
  explicit BopSceneWriter(std::string scene_dir);

  // Creates the folder tree. kInternal naming the folder on failure.
  [[nodiscard]] absl::Status Create() const;

  // Records frame metadata: id, timestamp, K, depth_scale, T_wc (must have has_pose) and
  // the objects (T_m2c and the scene_gt_info fields). Image paths in `frame` are ignored:
  // the standard paths above are listed in the TUM files. A repeated id replaces the old one.
  void AddFrame(const Frame& frame);

  // Writes scene_camera.json, scene_gt.json, scene_gt_info.json, rgb.txt, depth.txt,
  // groundtruth.txt. May be called again after more AddFrame calls.
  [[nodiscard]] absl::Status Finish() const;

  const std::string& dir() const { return dir_; }

 private:
  std::string dir_;
  std::map<int, Frame> frames_;
};

}  // namespace skimap::dataset

#endif  // SKIMAP_DATASET_WRITER_H_
