// Plain value types shared by the BOP and TUM readers and the BOP writer.
//
// Conventions (the same for real and synthetic data):
//   - Units: poses and translations in metres (BOP files store millimetres; the reader and
//     writer convert), pixels for intrinsics, depth images keep their raw uint16 values.
//   - Pixel centres are at integer coordinates: u = fx * x / z + cx (OpenCV / BOP).
//   - Camera frame: x right, y down, z forward (OpenCV).
//   - T_wc maps camera coordinates to world coordinates (world <- camera). BOP stores the
//     inverse: x_cam = cam_R_w2c * x_world + cam_t_w2c.
//   - T_m2c maps model coordinates to camera coordinates (BOP cam_R_m2c, cam_t_m2c).
//     The object pose in the world is T_wc * T_m2c.
//
// Thread safety: plain values; const access from several threads is safe.
#ifndef SKIMAP_DATASET_TYPES_H_
#define SKIMAP_DATASET_TYPES_H_

#include <Eigen/Geometry>
#include <array>
#include <map>
#include <string>
#include <vector>

namespace skimap::dataset {

// Pinhole intrinsics without distortion (BOP cam_K) and the image size they belong to.
struct Intrinsics {
  double fx = 0, fy = 0, cx = 0, cy = 0;  // pixels
  int width = 0, height = 0;              // pixels
};

// Dataset-wide camera description (BOP camera.json). depth_scale: raw depth value *
// depth_scale = millimetres (BOP convention; 0.1 for YCB-Video, 0.2 for skimap-sim and TUM).
struct CameraInfo {
  Intrinsics K;
  double depth_scale = 1.0;
};

// One annotated object instance in one frame (BOP scene_gt.json + scene_gt_info.json).
struct ObjectAnnotation {
  int obj_id = 0;                                           // BOP object id (1-based)
  Eigen::Isometry3d T_m2c = Eigen::Isometry3d::Identity();  // model -> camera, metres
  std::string mask_visib_path;  // "" if the dataset has no mask_visib/ image for it
  // From scene_gt_info.json; -1 when absent. bbox = [x, y, w, h] (bop_toolkit convention).
  std::array<int, 4> bbox_obj = {-1, -1, -1, -1};    // whole object, occlusion ignored
  std::array<int, 4> bbox_visib = {-1, -1, -1, -1};  // visible part
  int px_count_all = -1;                             // pixels of the unoccluded object
  int px_count_visib = -1;
  int px_count_valid = -1;
  double visib_fract = -1;
};

// One RGB-D frame: metadata and image paths only. Images are loaded on demand with
// LoadFrameImages() (reader.h), so a long sequence costs a few hundred bytes per frame.
struct Frame {
  int id = 0;              // BOP image id (as in the file names) or TUM line index
  double timestamp = 0;    // seconds; BOP has none, so id / 30 is used there
  Intrinsics K;            //
  double depth_scale = 1;  // raw depth * depth_scale = millimetres
  bool has_pose = false;   // false if the dataset has no camera pose for this frame
  Eigen::Isometry3d T_wc = Eigen::Isometry3d::Identity();  // world <- camera, metres
  std::string rgb_path;                   // absolute or relative to the working directory
  std::string depth_path;                 // "" if the frame has no depth image
  std::vector<ObjectAnnotation> objects;  // empty for TUM
};

// Object model metadata (BOP models_info.json), converted to metres.
struct ModelInfo {
  int obj_id = 0;
  double diameter = 0;            // metres: largest distance between two model points
  Eigen::Vector3d min{0, 0, 0};   // bounding box corner, model frame, metres
  Eigen::Vector3d size{0, 0, 0};  // bounding box extent, metres
  std::string ply_path;           // models/obj_XXXXXX.ply if that file exists, else ""
  // The model's symmetries (model <- model, metres) from models_info.json: every
  // symmetries_discrete transform, and each symmetries_continuous axis sampled every
  // kContinuousSymmetryStepDeg degrees (BOP convention: a pose P and P * S look the same).
  // The identity is not listed. Empty for an object without symmetries.
  std::vector<Eigen::Isometry3d> symmetries;
};
inline constexpr double kContinuousSymmetryStepDeg = 2.0;

// A sequence of frames (a BOP scene folder or a TUM sequence).
struct Sequence {
  std::string dir;            // folder the sequence was read from
  std::vector<Frame> frames;  // sorted by id (BOP) or timestamp (TUM)
};

}  // namespace skimap::dataset

#endif  // SKIMAP_DATASET_TYPES_H_
