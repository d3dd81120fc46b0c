#include "bench/ycbv_frames.h"

#include <algorithm>
#include <cstdio>
#include <cstdlib>

#include "client/cli/dataset_frames.h"
#include "server/core/maps/frame_decode.h"

namespace skimap::bench {
namespace {

[[noreturn]] void ExitWith(const std::string& what) {
  std::fprintf(stderr, "ycbv frames: %s\n", what.c_str());
  std::exit(1);
}

}  // namespace

perception::RgbdFrame ToRgbdFrame(const RealFrame& f) {
  perception::RgbdFrame frame;
  const v1::CameraIntrinsics& k = f.api.intrinsics();
  frame.camera = {k.fx(), k.fy(), k.cx(), k.cy(), f.depth.width, f.depth.height};
  frame.depth = f.depth;
  frame.color = f.color;
  frame.depth_scale = f.api.depth_scale();
  const v1::Pose& p = f.api.pose();
  frame.pose.translation = {p.translation().x(), p.translation().y(), p.translation().z()};
  frame.pose.rotation =
      Eigen::Quaterniond(p.rotation().w(), p.rotation().x(), p.rotation().y(), p.rotation().z());
  return frame;
}

std::vector<RealFrame> LoadYcbvFrames(const std::string& root, size_t every, size_t limit) {
  absl::StatusOr<std::vector<dataset::Frame>> frames = client::LoadDatasetFrames(root);
  if (!frames.ok()) ExitWith(frames.status().ToString());
  std::vector<RealFrame> out;
  for (size_t i = 0; i < frames->size() && out.size() < limit; i += std::max<size_t>(every, 1)) {
    absl::StatusOr<v1::Frame> api = client::ToApiFrame((*frames)[i], "maps/bench", i + 1);
    if (!api.ok()) ExitWith(api.status().ToString());
    absl::StatusOr<perception::RgbdFrame> decoded = server::DecodeFrame(*api);
    if (!decoded.ok() || !decoded->color) ExitWith("ycbv frame does not decode with colour");
    RealFrame f{*std::move(api), std::move(decoded->depth), *std::move(decoded->color)};
    f.api.clear_depth();
    f.api.clear_color();
    out.push_back(std::move(f));
  }
  if (out.empty()) ExitWith("no frames in " + root);
  return out;
}

perception::DepthCodec ToDepthCodec(v1::DepthEncoding e) {
  switch (e) {
    case v1::DEPTH_ENCODING_PNG16:
      return perception::DepthCodec::kPng16;
    case v1::DEPTH_ENCODING_ZSTD:
      return perception::DepthCodec::kZstd;
    case v1::DEPTH_ENCODING_RVL:
      return perception::DepthCodec::kRvl;
    default:
      return perception::DepthCodec::kRawU16;
  }
}

perception::ColorCodec ToColorCodec(v1::ColorEncoding e) {
  return e == v1::COLOR_ENCODING_PNG    ? perception::ColorCodec::kPng
         : e == v1::COLOR_ENCODING_JPEG ? perception::ColorCodec::kJpeg
                                        : perception::ColorCodec::kRawRgb8;
}

EncodedFrames::EncodedFrames(const std::vector<RealFrame>& frames, const Codec& codec) {
  for (const RealFrame& f : frames) {
    absl::StatusOr<std::string> d = perception::EncodeDepth(ToDepthCodec(codec.depth), f.depth);
    absl::StatusOr<std::string> c = perception::EncodeColor(ToColorCodec(codec.color), f.color);
    if (!d.ok() || !c.ok()) ExitWith("a frame does not encode");
    v1::Frame e = f.api;
    e.set_depth_encoding(codec.depth);
    e.set_depth(*std::move(d));
    e.set_color_encoding(codec.color);
    e.set_color(*std::move(c));
    encoded_.push_back(std::move(e));
  }
}

v1::Frame EncodedFrames::Make(size_t k, const std::string& map, uint64_t sequence,
                              const Shift& shift) const {
  v1::Frame f = encoded_[k % encoded_.size()];
  f.set_map(map);
  f.set_sequence(sequence);
  v1::Vec3& t = *f.mutable_pose()->mutable_translation();
  t.set_x(t.x() + shift.x);
  t.set_y(t.y() + shift.y);
  t.set_z(t.z() + shift.z);
  return f;
}

double EncodedFrames::mean_bytes() const {
  double bytes = 0;
  for (const v1::Frame& f : encoded_) bytes += double(f.ByteSizeLong());
  return bytes / double(encoded_.size());
}

std::vector<std::shared_ptr<const v1::Frame>> EncodeFrames(
    const std::vector<RealFrame>& frames, const Codec& codec, size_t count,
    const std::function<Shift(size_t)>& shift) {
  const EncodedFrames encoded(frames, codec);
  std::vector<std::shared_ptr<const v1::Frame>> out;
  for (size_t k = 0; k < count; ++k) {
    out.push_back(
        std::make_shared<const v1::Frame>(encoded.Make(k, "maps/bench", k + 1, shift(k))));
  }
  return out;
}

}  // namespace skimap::bench
