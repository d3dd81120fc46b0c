// Readers for RGB-D datasets: BOP (https://github.com/thodan/bop_toolkit, docs/
// bop_datasets_format.md) and TUM RGB-D (rgb.txt, depth.txt, groundtruth.txt). One reader
// serves real data (../shared/data/ycbv-0000) and the output of skimap-sim alike.
//
// Usage:
//   auto seq = skimap::dataset::LoadSequence("data/sk/test/000001");   // BOP or TUM
//   for (const Frame& f : seq->frames) {
//     auto img = skimap::dataset::LoadFrameImages(f);   // rgb + depth (+ masks)
//     ...
//   }
//
// All functions return absl::Status errors naming the file and the field that is wrong
// (kNotFound for a missing file, kInvalidArgument for malformed content). No exceptions
// escape. Thread safety: every function is reentrant and may run concurrently.
#ifndef SKIMAP_DATASET_READER_H_
#define SKIMAP_DATASET_READER_H_

#include <map>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "dataset/types.h"

namespace skimap::dataset {

// Reads a BOP camera.json (fx, fy, cx, cy, width, height, depth_scale).
absl::StatusOr<CameraInfo> LoadBopCamera(const std::string& camera_json_path);

// Reads a BOP models_info.json; keys are obj_ids. ply_path is filled when
// <dir of json>/obj_XXXXXX.ply exists.
absl::StatusOr<std::map<int, ModelInfo>> LoadModelsInfo(const std::string& models_info_path);

// Options for LoadBopScene.
struct BopSceneOptions {
  // Used when the scene folder has no image size: BOP's scene_camera.json has no width/height.
  // If unset, camera.json is searched in the scene folder's parent and grandparent;
  // if none is found the size is taken from the first rgb image.
  std::optional<CameraInfo> camera;
  double fps = 30;  // BOP has no timestamps: timestamp = id / fps
};

// Reads one BOP scene folder (scene_camera.json required; scene_gt.json and
// scene_gt_info.json optional) into frames with lazy image paths. rgb images may be .png or
// .jpg. Frames without cam_R_w2c/cam_t_w2c get has_pose = false.
absl::StatusOr<Sequence> LoadBopScene(const std::string& scene_dir,
                                      const BopSceneOptions& options = {});

// A BOP dataset root: camera.json, models_info.json (root or models/), split folders.
struct BopDataset {
  std::string root;
  std::optional<CameraInfo> camera;  // from root camera.json if present
  std::map<int, ModelInfo> models;   // empty if there is no models_info.json
  // Scene folders per split, e.g. {"test", {"<root>/test/000000", ...}}, sorted.
  std::map<std::string, std::vector<std::string>> scenes;
};

// Reads the dataset root metadata and lists the scene folders (those with a
// scene_camera.json) of every split folder. Scenes are loaded with LoadBopScene.
absl::StatusOr<BopDataset> LoadBopDataset(const std::string& root);

// Default TUM intrinsics (freiburg "ROS default": fx = fy = 525, cx = 319.5, cy = 239.5).
Intrinsics TumDefaultIntrinsics();

// Options for LoadTumSequence.
struct TumOptions {
  Intrinsics K = TumDefaultIntrinsics();
  double depth_scale = 0.2;  // TUM depth PNGs are 5000 units per metre = 0.2 mm
  double max_dt = 0.02;      // s; rgb/depth/pose association tolerance (TUM tools use 0.02)
};

// Reads a TUM RGB-D sequence folder: rgb.txt, depth.txt ("timestamp path" lines, '#'
// comments) and, if present, groundtruth.txt ("t tx ty tz qx qy qz qw", world <- camera).
// Each rgb image is paired with the nearest depth image within max_dt (unpaired rgb images
// are dropped) and the nearest pose within max_dt (else has_pose = false).
absl::StatusOr<Sequence> LoadTumSequence(const std::string& dir, const TumOptions& options = {});

// Loads a BOP scene folder (has scene_camera.json) or a TUM folder (has rgb.txt).
absl::StatusOr<Sequence> LoadSequence(const std::string& dir);

// Decoded images of one frame.
struct FrameImages {
  cv::Mat rgb;                 // CV_8UC3, BGR (OpenCV order)
  cv::Mat depth;               // CV_16UC1 raw values (* depth_scale = mm); empty if no depth
  std::vector<cv::Mat> masks;  // CV_8UC1 0/255 per frame.objects entry (empty Mat if none)
};

// Reads the frame's images from disk. Fails if a file is missing or unreadable, if depth is
// not 16-bit single channel, or if any image size differs from frame.K (when K has a size).
absl::StatusOr<FrameImages> LoadFrameImages(const Frame& frame, bool load_masks = false);

// Converts a raw depth image to metres (CV_32FC1; 0 stays 0 = no depth).
cv::Mat DepthToMeters(const cv::Mat& raw_depth, double depth_scale);

}  // namespace skimap::dataset

#endif  // SKIMAP_DATASET_READER_H_
