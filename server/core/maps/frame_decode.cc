#include "server/core/maps/frame_decode.h"

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

absl::Status DecodeFrameHeader(const v1::Frame& f, perception::RgbdFrame* out) {
  if (!f.has_intrinsics()) return absl::InvalidArgumentError("intrinsics is required");
  const v1::CameraIntrinsics& k = f.intrinsics();
  if (k.width() > 8192 || k.height() > 8192) {
    return absl::InvalidArgumentError("intrinsics.width/height must be in 1..8192");
  }
  out->camera = {
      k.fx(), k.fy(), k.cx(), k.cy(), static_cast<int>(k.width()), static_cast<int>(k.height())};
  if (absl::Status s = perception::ValidateCamera(out->camera); !s.ok()) return s;
  absl::StatusOr<perception::CameraPose> pose = DecodePose(f.pose(), f.has_pose());
  if (!pose.ok()) return pose.status();
  out->pose = *pose;
  out->depth_scale = f.depth_scale();
  if (!(out->depth_scale > 0) || !std::isfinite(out->depth_scale)) {
    return absl::InvalidArgumentError("depth_scale must be finite and > 0");
  }
  return absl::OkStatus();
}

absl::Status DecodeFrameDepth(const v1::Frame& f, perception::RgbdFrame* out) {
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
    case v1::DEPTH_ENCODING_RVL:
      depth_codec = perception::DepthCodec::kRvl;
      break;
    default:
      return absl::InvalidArgumentError("depth_encoding must be RAW_U16, PNG16, ZSTD or RVL");
  }
  return perception::DecodeDepthInto(depth_codec, f.depth(), out->camera.width, out->camera.height,
                                     &out->depth);
}

absl::Status DecodeFrameColor(const v1::Frame& f, perception::RgbdFrame* out) {
  perception::ColorCodec color_codec;
  switch (f.color_encoding()) {
    case v1::COLOR_ENCODING_NONE:
      if (!f.color().empty()) {
        return absl::InvalidArgumentError("color_encoding is required when color is set");
      }
      out->color.reset();
      return absl::OkStatus();
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
  if (!out->color) out->color.emplace();
  return perception::DecodeColorInto(color_codec, f.color(), out->camera.width, out->camera.height,
                                     &*out->color);
}

absl::Status DecodeFrameInto(const v1::Frame& f, perception::RgbdFrame* out) {
  if (absl::Status s = DecodeFrameHeader(f, out); !s.ok()) return s;
  if (absl::Status s = DecodeFrameDepth(f, out); !s.ok()) return s;
  return DecodeFrameColor(f, out);
}

absl::StatusOr<perception::RgbdFrame> DecodeFrame(const v1::Frame& f) {
  perception::RgbdFrame out;
  if (absl::Status s = DecodeFrameInto(f, &out); !s.ok()) return s;
  return out;
}

}  // namespace skimap::server
