#include "server/maps/frame_decode.h"

namespace skimap::server {

absl::StatusOr<perception::CameraPose> DecodePose(const v1::Pose& pose, bool present) {
  if (!present || !pose.has_rotation()) {
    return absl::InvalidArgumentError("pose.rotation is required");
  }
  perception::CameraPose out;
  const v1::Quaternion& q = pose.rotation();
  out.rotation = Eigen::Quaterniond(q.w(), q.x(), q.y(), q.z());
  out.translation = {pose.translation().x(), pose.translation().y(), pose.translation().z()};
  if (absl::Status s = perception::ValidatePose(out); !s.ok()) return s;
  return out;
}

absl::StatusOr<perception::RgbdFrame> DecodeFrame(const v1::Frame& f) {
  perception::RgbdFrame out;
  if (!f.has_intrinsics()) return absl::InvalidArgumentError("intrinsics is required");
  const v1::CameraIntrinsics& k = f.intrinsics();
  if (k.width() > 8192 || k.height() > 8192) {
    return absl::InvalidArgumentError("intrinsics.width/height must be in 1..8192");
  }
  out.camera = {
      k.fx(), k.fy(), k.cx(), k.cy(), static_cast<int>(k.width()), static_cast<int>(k.height())};
  if (absl::Status s = perception::ValidateCamera(out.camera); !s.ok()) return s;
  absl::StatusOr<perception::CameraPose> pose = DecodePose(f.pose(), f.has_pose());
  if (!pose.ok()) return pose.status();
  out.pose = *pose;
  out.depth_scale = f.depth_scale();
  if (!(out.depth_scale > 0) || !std::isfinite(out.depth_scale)) {
    return absl::InvalidArgumentError("depth_scale must be finite and > 0");
  }
  perception::DepthCodec depth_codec;
  switch (f.depth_encoding()) {
    case v1::DEPTH_ENCODING_RAW_U16:
      depth_codec = perception::DepthCodec::kRawU16;
      break;
    case v1::DEPTH_ENCODING_PNG16:
      depth_codec = perception::DepthCodec::kPng16;
      break;
    case v1::DEPTH_ENCODING_ZSTD:
      depth_codec = perception::DepthCodec::kZstd;
      break;
    default:
      return absl::InvalidArgumentError("depth_encoding must be RAW_U16, PNG16 or ZSTD");
  }
  absl::StatusOr<perception::DepthImage> depth =
      perception::DecodeDepth(depth_codec, f.depth(), out.camera.width, out.camera.height);
  if (!depth.ok()) return depth.status();
  out.depth = *std::move(depth);
  perception::ColorCodec color_codec;
  switch (f.color_encoding()) {
    case v1::COLOR_ENCODING_NONE:
      if (!f.color().empty()) {
        return absl::InvalidArgumentError("color_encoding is required when color is set");
      }
      return out;
    case v1::COLOR_ENCODING_RAW_RGB8:
      color_codec = perception::ColorCodec::kRawRgb8;
      break;
    case v1::COLOR_ENCODING_PNG:
      color_codec = perception::ColorCodec::kPng;
      break;
    case v1::COLOR_ENCODING_JPEG:
      color_codec = perception::ColorCodec::kJpeg;
      break;
    default:
      return absl::InvalidArgumentError("color_encoding: unknown value");
  }
  absl::StatusOr<perception::ColorImage> color =
      perception::DecodeColor(color_codec, f.color(), out.camera.width, out.camera.height);
  if (!color.ok()) return color.status();
  out.color = *std::move(color);
  return out;
}

}  // namespace skimap::server
