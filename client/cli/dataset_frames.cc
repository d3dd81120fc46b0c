#include "client/cli/dataset_frames.h"

#include <algorithm>
#include <filesystem>
#include <fstream>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "codec/image_files.h"
#include "codec/image_header.h"
#include "dataset/reader.h"

namespace skimap::client {
namespace {

// True if `bytes` claim to be a 16-bit greyscale PNG (its header only: a damaged file is
// refused by the server, naming the frame's depth).
bool IsPng16Grey(const std::string& bytes) {
  absl::StatusOr<perception::ImageHeader> h =
      perception::ReadImageHeader(perception::ImageFormat::kPng, bytes, "depth");
  return h.ok() && h->bit_depth == 16 && h->channels == 1;
}

absl::StatusOr<std::string> ReadBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) return absl::NotFoundError(absl::StrCat("cannot read ", path));
  std::string bytes(static_cast<size_t>(in.tellg()), '\0');
  in.seekg(0);
  if (!in.read(bytes.data(), static_cast<std::streamsize>(bytes.size()))) {
    return absl::NotFoundError(absl::StrCat("cannot read ", path));
  }
  return bytes;
}

}  // namespace

absl::StatusOr<std::vector<dataset::Frame>> LoadDatasetFrames(const std::string& path) {
  namespace fs = std::filesystem;
  if (fs::exists(fs::path(path) / "scene_camera.json") || fs::exists(fs::path(path) / "rgb.txt")) {
    absl::StatusOr<dataset::Sequence> seq = dataset::LoadSequence(path);
    if (!seq.ok()) return seq.status();
    return std::move(seq->frames);
  }
  absl::StatusOr<dataset::BopDataset> bop = dataset::LoadBopDataset(path);
  if (!bop.ok()) return bop.status();
  std::vector<dataset::Frame> frames;
  for (const auto& [split, scenes] : bop->scenes) {
    for (const std::string& scene : scenes) {
      dataset::BopSceneOptions options;
      options.camera = bop->camera;
      absl::StatusOr<dataset::Sequence> seq = dataset::LoadBopScene(scene, options);
      if (!seq.ok()) return seq.status();
      frames.insert(frames.end(), seq->frames.begin(), seq->frames.end());
    }
  }
  if (frames.empty()) {
    return absl::NotFoundError(absl::StrCat(path, ": no BOP scene or TUM sequence found"));
  }
  return frames;
}

std::vector<dataset::Frame> KeepEvery(std::vector<dataset::Frame> frames, int every,
                                      int max_frames) {
  if (every <= 1 && max_frames <= 0) return frames;
  std::vector<dataset::Frame> kept;
  for (size_t i = 0; i < frames.size(); i += std::max(1, every)) {
    if (max_frames > 0 && static_cast<int>(kept.size()) >= max_frames) break;
    kept.push_back(std::move(frames[i]));
  }
  return kept;
}

absl::StatusOr<v1::Frame> ToApiFrame(const dataset::Frame& f, const std::string& map_name,
                                     uint64_t sequence, v1::DepthEncoding depth_encoding) {
  if (!f.has_pose) {
    return absl::FailedPreconditionError(absl::StrCat("frame ", f.id, " has no camera pose"));
  }
  if (f.depth_path.empty()) {
    return absl::FailedPreconditionError(absl::StrCat("frame ", f.id, " has no depth image"));
  }
  v1::Frame out;
  out.set_map(map_name);
  out.set_sequence(sequence);
  const double seconds = std::floor(f.timestamp);
  out.mutable_timestamp()->set_seconds(static_cast<int64_t>(seconds));
  out.mutable_timestamp()->set_nanos(static_cast<int32_t>((f.timestamp - seconds) * 1e9));
  ToApiPose(f.T_wc, out.mutable_pose());
  v1::CameraIntrinsics* k = out.mutable_intrinsics();
  k->set_fx(f.K.fx);
  k->set_fy(f.K.fy);
  k->set_cx(f.K.cx);
  k->set_cy(f.K.cy);
  k->set_width(f.K.width);
  k->set_height(f.K.height);
  absl::StatusOr<std::string> depth = ReadBytes(f.depth_path);
  if (!depth.ok()) return depth.status();
  if (depth_encoding == v1::DEPTH_ENCODING_PNG16 ||
      (depth_encoding == kDepthAsStored && IsPng16Grey(*depth))) {
    out.set_depth_encoding(v1::DEPTH_ENCODING_PNG16);
    out.set_depth(*std::move(depth));
  } else {
    if (depth_encoding == kDepthAsStored) depth_encoding = kDefaultDepthEncoding;
    const cv::Mat pixels =
        perception::DecodeImage(*depth, perception::ImageMode::kAnyDepth).value_or(cv::Mat());
    if (pixels.type() != CV_16UC1 || !pixels.isContinuous()) {
      return absl::InvalidArgumentError(
          absl::StrCat(f.depth_path, ": depth is not a 16-bit greyscale PNG"));
    }
    absl::Status s =
        SetFrameDepth(pixels.ptr<uint16_t>(), pixels.cols, pixels.rows, &out, depth_encoding);
    if (!s.ok()) return s;
  }
  out.set_depth_scale(f.depth_scale / 1000.0);  // dataset: mm per unit; API: metres
  if (!f.rgb_path.empty()) {
    absl::StatusOr<std::string> color = ReadBytes(f.rgb_path);
    if (!color.ok()) return color.status();
    const std::string lower = absl::AsciiStrToLower(f.rgb_path);
    out.set_color_encoding(absl::EndsWith(lower, ".png") ? v1::COLOR_ENCODING_PNG
                                                         : v1::COLOR_ENCODING_JPEG);
    out.set_color(*std::move(color));
  }
  return out;
}

absl::StatusOr<v1::ClassifyImageRequest> ToClassifyImageRequest(const dataset::Frame& f) {
  if (f.rgb_path.empty() || f.K.width <= 0 || f.K.height <= 0) {
    return absl::FailedPreconditionError(
        absl::StrCat("frame ", f.id, ": no colour image or no image size to classify"));
  }
  absl::StatusOr<std::string> color = ReadBytes(f.rgb_path);
  if (!color.ok()) return color.status();
  v1::ClassifyImageRequest request;
  const std::string lower = absl::AsciiStrToLower(f.rgb_path);
  request.set_color_encoding(absl::EndsWith(lower, ".png") ? v1::COLOR_ENCODING_PNG
                                                           : v1::COLOR_ENCODING_JPEG);
  request.set_color(*std::move(color));
  request.set_width(f.K.width);
  request.set_height(f.K.height);
  request.set_return_matches(true);
  return request;
}

void ToApiPose(const Eigen::Isometry3d& T, v1::Pose* pose) {
  const Eigen::Quaterniond q(T.rotation());
  const Eigen::Vector3d t = T.translation();
  pose->mutable_rotation()->set_w(q.w());
  pose->mutable_rotation()->set_x(q.x());
  pose->mutable_rotation()->set_y(q.y());
  pose->mutable_rotation()->set_z(q.z());
  pose->mutable_translation()->set_x(t.x());
  pose->mutable_translation()->set_y(t.y());
  pose->mutable_translation()->set_z(t.z());
}

}  // namespace skimap::client
