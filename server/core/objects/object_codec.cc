#include "server/core/objects/object_codec.h"

#include <cmath>
#include <opencv2/imgproc.hpp>

#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/strip.h"
#include "base/echo.h"
#include "base/encoding.h"
#include "codec/image_files.h"
#include "codec/image_header.h"
#include "server/core/maps/frame_decode.h"
#include "skimap/serialization.h"

namespace skimap::server {
namespace {

absl::Status Prefixed(absl::string_view prefix, const absl::Status& s) {
  return absl::Status(s.code(), absl::StrCat(prefix, s.message()));
}

}  // namespace

std::string ObjectName(int obj_id) { return absl::StrCat("objects/", obj_id); }

absl::StatusOr<int> ParseObjectName(absl::string_view name, absl::string_view field) {
  int id = 0;
  absl::string_view rest = name;
  if (!absl::ConsumePrefix(&rest, "objects/") || !absl::SimpleAtoi(rest, &id) || id < 1 ||
      id > kMaxObjId) {
    return absl::InvalidArgumentError(
        absl::StrCat(field, ": ", Echo(name), " is not an object name objects/{1..999999}"));
  }
  return id;
}

absl::Status CheckObjId(uint32_t obj_id) {
  if (obj_id < 1 || obj_id > kMaxObjId) {
    return absl::InvalidArgumentError(absl::StrCat("obj_id: ", obj_id, " must be in 1..999999"));
  }
  return absl::OkStatus();
}

absl::StatusOr<objects::ObjectDatabaseParams> ApplyTrainingParams(
    const v1::TrainingParams& api, const objects::ObjectDatabaseParams& base) {
  objects::ObjectDatabaseParams p = base;
  if (!api.detector().empty()) p.features.detector = api.detector();
  if (api.has_max_features()) p.features.max_features = static_cast<int>(api.max_features());
  if (api.has_resolution()) p.resolution = api.resolution();
  if (api.has_bandwidth()) p.mean_shift.bandwidth = api.bandwidth();
  if (api.has_mask_erosion_px()) p.mask_erosion_px = static_cast<int>(api.mask_erosion_px());
  if (api.has_zoom_out()) p.zoom_out = api.zoom_out();
  if (!api.detector().empty() && !absl::EqualsIgnoreCase(api.detector(), base.features.detector)) {
    // Detector defaults follow the new detector unless given.
    if (!api.has_bandwidth()) p.mean_shift.bandwidth = 0;
    p.verify_threshold = 0;
    p.instances = {};
  }
  absl::StatusOr<objects::ObjectDatabaseParams> r = objects::ResolveParams(p);
  if (!r.ok()) return Prefixed("params.", r.status());
  return r;
}

absl::StatusOr<objects::ObjectDatabaseParams> ApplyClassifierParams(
    const v1::ClassifierParams& api, const objects::ObjectDatabaseParams& base) {
  objects::ObjectDatabaseParams p = base;
  if (api.has_classes_per_object())
    p.classes_per_object = static_cast<int>(api.classes_per_object());
  if (api.has_trees()) p.forest.trees = static_cast<int>(api.trees());
  if (api.has_max_depth()) p.forest.max_depth = static_cast<int>(api.max_depth());
  if (api.has_max_samples_per_class())
    p.max_samples_per_class = static_cast<int>(api.max_samples_per_class());
  if (api.has_verify_threshold()) p.verify_threshold = api.verify_threshold();
  if (api.has_top_n()) p.top_n = static_cast<int>(api.top_n());
  if (api.has_min_instance_score()) p.instances.min_score = api.min_instance_score();
  if (api.has_min_instance_fit()) p.instances.min_fit = api.min_instance_fit();
  if (api.has_max_view_conflict()) p.instances.max_view_conflict = api.max_view_conflict();
  absl::StatusOr<objects::ObjectDatabaseParams> r = objects::ResolveParams(p);
  if (!r.ok()) return Prefixed("params.", r.status());
  return r;
}

absl::Status CheckSameTraining(const objects::ObjectDatabaseParams& t,
                               const objects::ObjectDatabaseParams& db) {
  auto differs = [&](absl::string_view field, const auto& a, const auto& b) {
    return absl::FailedPreconditionError(absl::StrCat(
        "params.", field, ": ", a, " differs from the object database's ", b,
        " (all objects share the training parameters; delete every object to change them)"));
  };
  if (t.features.detector != db.features.detector)
    return differs("detector", t.features.detector, db.features.detector);
  if (t.features.max_features != db.features.max_features)
    return differs("max_features", t.features.max_features, db.features.max_features);
  if (t.resolution != db.resolution) return differs("resolution", t.resolution, db.resolution);
  if (!(t.mean_shift == db.mean_shift))
    return differs("bandwidth", t.mean_shift.bandwidth, db.mean_shift.bandwidth);
  if (t.mask_erosion_px != db.mask_erosion_px)
    return differs("mask_erosion_px", t.mask_erosion_px, db.mask_erosion_px);
  if (t.zoom_out != db.zoom_out) return differs("zoom_out", t.zoom_out, db.zoom_out);
  return absl::OkStatus();
}

v1::TrainingParams ToApiTrainingParams(const objects::ObjectDatabaseParams& p) {
  v1::TrainingParams out;
  out.set_detector(p.features.detector);
  out.set_max_features(p.features.max_features);
  out.set_resolution(p.resolution);
  out.set_bandwidth(p.mean_shift.bandwidth);
  out.set_mask_erosion_px(p.mask_erosion_px);
  out.set_zoom_out(p.zoom_out);
  return out;
}

v1::ClassifierParams ToApiClassifierParams(const objects::ObjectDatabaseParams& p) {
  v1::ClassifierParams out;
  out.set_classes_per_object(p.classes_per_object);
  out.set_trees(p.forest.trees);
  out.set_max_depth(p.forest.max_depth);
  out.set_max_samples_per_class(p.max_samples_per_class);
  out.set_verify_threshold(p.verify_threshold);
  out.set_top_n(p.top_n);
  out.set_min_instance_score(p.instances.min_score);
  out.set_min_instance_fit(p.instances.min_fit);
  out.set_max_view_conflict(p.instances.max_view_conflict);
  return out;
}

absl::StatusOr<cv::Mat> DecodeMask(v1::MaskEncoding encoding, const std::string& bytes, int width,
                                   int height, absl::string_view field) {
  if (bytes.empty()) return absl::InvalidArgumentError(absl::StrCat(field, ": missing mask"));
  cv::Mat mask;
  if (encoding == v1::MASK_ENCODING_RAW_U8) {
    if (bytes.size() != static_cast<size_t>(width) * height) {
      return absl::InvalidArgumentError(
          absl::StrCat(field, ": RAW_U8 needs ", width * height, " bytes, got ", bytes.size()));
    }
    mask = cv::Mat(height, width, CV_8UC1, const_cast<char*>(bytes.data())).clone();
  } else if (encoding == v1::MASK_ENCODING_PNG) {
    // The header first: a PNG claiming huge dimensions must not size a buffer.
    absl::StatusOr<perception::ImageHeader> h =
        perception::ReadImageHeader(perception::ImageFormat::kPng, bytes, field);
    if (!h.ok()) return h.status();
    if (h->width != width || h->height != height || h->bit_depth > 8) {
      return absl::InvalidArgumentError(
          absl::StrCat(field, ": PNG header claims ", h->width, "x", h->height, " at ",
                       h->bit_depth, " bits, expected an 8-bit ", width, "x", height, " mask"));
    }
    absl::StatusOr<cv::Mat> decoded = perception::DecodeImage(bytes, perception::ImageMode::kGrey);
    if (decoded.ok()) mask = *std::move(decoded);
    if (mask.empty()) return absl::InvalidArgumentError(absl::StrCat(field, ": not a PNG"));
    if (mask.cols != width || mask.rows != height) {
      return absl::InvalidArgumentError(absl::StrCat(
          field, ": ", mask.cols, "x", mask.rows, " differs from the image ", width, "x", height));
    }
  } else {
    return absl::InvalidArgumentError(absl::StrCat(field, "_encoding: must be RAW_U8 or PNG"));
  }
  return mask;
}

absl::StatusOr<objects::TrainingFrame> DecodeTrainingFrame(const v1::TrainingFrame& f) {
  if (f.depth().empty()) return absl::InvalidArgumentError("depth: missing depth image");
  if (f.color().empty() || f.color_encoding() == v1::COLOR_ENCODING_NONE) {
    return absl::InvalidArgumentError("color: missing colour image (features are detected on it)");
  }
  // The image part is a Frame without a camera pose; reuse its decoder.
  v1::Frame frame;
  *frame.mutable_intrinsics() = f.intrinsics();
  frame.mutable_pose()->mutable_rotation()->set_w(1);
  frame.set_depth_encoding(f.depth_encoding());
  frame.set_depth(f.depth());
  frame.set_depth_scale(f.depth_scale());
  frame.set_color_encoding(f.color_encoding());
  frame.set_color(f.color());
  absl::StatusOr<perception::RgbdFrame> rgbd = DecodeFrame(frame);
  if (!rgbd.ok()) return rgbd.status();
  absl::StatusOr<perception::CameraPose> pose = DecodePose(f.object_pose(), f.has_object_pose());
  if (!pose.ok()) return Prefixed("object_", pose.status());
  const int w = rgbd->camera.width, h = rgbd->camera.height;
  absl::StatusOr<cv::Mat> mask = DecodeMask(f.mask_encoding(), f.mask(), w, h, "mask");
  if (!mask.ok()) return mask.status();
  if (cv::countNonZero(*mask) == 0) {
    return absl::InvalidArgumentError("mask: empty (the object is not visible in this frame)");
  }
  objects::TrainingFrame out;
  cv::Mat rgb(h, w, CV_8UC3, rgbd->color->rgb.data());
  cv::cvtColor(rgb, out.bgr, cv::COLOR_RGB2BGR);
  out.depth = cv::Mat(h, w, CV_16UC1, rgbd->depth.pixels.data()).clone();
  out.depth_scale = rgbd->depth_scale * 1000.0;  // TrainingFrame: millimetres per unit
  out.K = {rgbd->camera.fx, rgbd->camera.fy, rgbd->camera.cx, rgbd->camera.cy};
  out.T_m2c = Eigen::Isometry3d::Identity();
  out.T_m2c.linear() = pose->rotation.normalized().toRotationMatrix();
  out.T_m2c.translation() = pose->translation;
  out.mask = *std::move(mask);
  return out;
}

v1::Object ToApiObject(const objects::ObjectModel& m, const objects::ObjectDatabaseParams& p,
                       bool in_classifier) {
  v1::Object out;
  out.set_name(ObjectName(m.obj_id));
  out.set_obj_id(m.obj_id);
  out.set_display_name(m.name);
  out.set_frames(m.stats.frames);
  out.set_features(m.stats.features);
  out.set_descriptors(m.stats.descriptors);
  out.set_voxels(m.voxels.size());
  uint64_t centroids = 0;
  for (const objects::VoxelModel& v : m.voxels) centroids += v.centroids.rows();
  out.set_centroids(centroids);
  out.set_raw_descriptor_bytes(m.stats.raw_descriptor_bytes);
  out.set_centroid_bytes(m.stats.centroid_bytes);
  *out.mutable_params() = ToApiTrainingParams(p);
  out.set_in_classifier(in_classifier);
  return out;
}

absl::Status AddRgbVoxels(const objects::ObjectModel& model, double resolution, v1::Object* out) {
  out->set_rgb_resolution(resolution);
  if (model.rgb_volume.empty()) return absl::OkStatus();
  absl::StatusOr<std::unique_ptr<SkiMap<RGBWeightedVoxel>>> map =
      DeserializeMap<RGBWeightedVoxel>(model.rgb_volume, {});
  if (!map.ok()) return map.status();
  const double res = (*map)->options().resolution;
  (*map)->ForEach([&](const VoxelKey& key, const RGBWeightedVoxel& v) {
    if (!(v.weight > 0)) return;
    v1::Voxel* out_v = out->add_rgb_voxels();
    out_v->mutable_center()->set_x((key.x + 0.5) * res);
    out_v->mutable_center()->set_y((key.y + 0.5) * res);
    out_v->mutable_center()->set_z((key.z + 0.5) * res);
    auto channel = [&](float sum) {
      return static_cast<uint32_t>(std::clamp(std::lround(sum / v.weight), 0L, 255L));
    };
    out_v->set_rgb(channel(v.r) << 16 | channel(v.g) << 8 | channel(v.b));
    out_v->set_weight(v.weight);
  });
  return absl::OkStatus();
}

std::vector<std::string> EncodeRawDescriptors(const std::vector<objects::DescriptorMatrix>& raw) {
  std::vector<std::string> out;
  out.reserve(raw.size());
  for (const objects::DescriptorMatrix& m : raw) {
    std::string blob;
    Encoder e(&blob);
    m.Encode(e);
    out.push_back(std::move(blob));
  }
  return out;
}

absl::StatusOr<std::vector<objects::DescriptorMatrix>> DecodeRawDescriptors(
    const std::vector<std::string>& blobs, const objects::DescriptorLayout& layout) {
  std::vector<objects::DescriptorMatrix> out(blobs.size());
  for (size_t i = 0; i < blobs.size(); ++i) {
    Decoder d(blobs[i]);
    if (!objects::DescriptorMatrix::Decode(d, &out[i]) ||
        !(out[i].layout() == layout || out[i].empty())) {
      return absl::DataLossError(absl::StrCat("training_descriptors: voxel ", i, " is corrupt"));
    }
  }
  return out;
}

}  // namespace skimap::server
