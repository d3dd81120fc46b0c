#include "client/cli/model_views.h"

#include "absl/strings/str_cat.h"
#include "client/cli/dataset_frames.h"
#include "codec/image_files.h"
#include "dataset/reader.h"
#include "sim/model_io.h"
#include "sim/training_views.h"

namespace skimap::client {
namespace {

absl::StatusOr<std::string> Png(const cv::Mat& image, const std::string& what) {
  absl::StatusOr<std::string> bytes = perception::EncodeImage(".png", image);
  if (!bytes.ok()) return absl::InternalError(absl::StrCat("cannot encode the ", what, " as PNG"));
  return bytes;
}

}  // namespace

absl::StatusOr<std::vector<v1::TrainingFrame>> ModelTrainingFrames(
    const std::string& path, const ModelViewOptions& options) {
  absl::StatusOr<sim::ModelUnits> units = sim::ParseModelUnits(options.units, "--model_units");
  if (!units.ok()) return units.status();
  dataset::Intrinsics K{525.0, 525.0, 319.5, 239.5, 640, 480};
  if (!options.camera.empty()) {
    absl::StatusOr<dataset::CameraInfo> camera = dataset::LoadBopCamera(options.camera);
    if (!camera.ok()) return camera.status();
    K = camera->K;
  }
  absl::StatusOr<sim::Mesh> mesh = sim::LoadModel(path, {.units = *units});
  if (!mesh.ok()) return mesh.status();
  sim::TrainingViewOptions view_options;
  view_options.distances = options.distances;
  view_options.azimuths = options.azimuths;
  view_options.clutter = options.effects.clutter;
  view_options.lighting = options.effects.lighting;
  view_options.sensor = options.effects.sensor;
  const std::vector<sim::TrainingView> views = sim::RenderTrainingViews(*mesh, K, view_options);
  if (views.empty()) {
    return absl::FailedPreconditionError(absl::StrCat(
        path, ": no training view shows the model (check --model_units: is it in metres?)"));
  }
  std::vector<v1::TrainingFrame> frames;
  for (const sim::TrainingView& v : views) {
    v1::TrainingFrame f;
    v1::CameraIntrinsics* k = f.mutable_intrinsics();
    k->set_fx(K.fx);
    k->set_fy(K.fy);
    k->set_cx(K.cx);
    k->set_cy(K.cy);
    k->set_width(K.width);
    k->set_height(K.height);
    absl::StatusOr<std::string> depth = Png(v.depth_mm, "depth");
    absl::StatusOr<std::string> color = Png(v.bgr, "colour");
    absl::StatusOr<std::string> mask = Png(v.mask, "mask");
    if (!depth.ok()) return depth.status();
    if (!color.ok()) return color.status();
    if (!mask.ok()) return mask.status();
    f.set_depth_encoding(v1::DEPTH_ENCODING_PNG16);
    f.set_depth(*std::move(depth));
    f.set_depth_scale(0.001);
    f.set_color_encoding(v1::COLOR_ENCODING_PNG);
    f.set_color(*std::move(color));
    f.set_mask_encoding(v1::MASK_ENCODING_PNG);
    f.set_mask(*std::move(mask));
    ToApiPose(v.T_m2c, f.mutable_object_pose());
    frames.push_back(std::move(f));
  }
  return frames;
}

}  // namespace skimap::client
