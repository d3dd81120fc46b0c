#include "ros/bag/rectify.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "absl/strings/str_cat.h"
#include "codec/image_codec.h"

namespace skimap::bag {

// One camera's undistortion maps (cv::remap's fixed-point form) and the camera_info they
// are for.
struct Rectifier::Maps {
  sensor_msgs::CameraInfo camera;
  cv::Mat map1, map2;
};

namespace {

// What the maps depend on: the size, K and the distortion.
bool SameCamera(const sensor_msgs::CameraInfo& a, const sensor_msgs::CameraInfo& b) {
  return a.width == b.width && a.height == b.height && a.K == b.K &&
         a.distortion_model == b.distortion_model && a.D == b.D;
}

}  // namespace

bool HasDistortion(const sensor_msgs::CameraInfo& info) {
  for (double d : info.D) {
    if (d != 0) return true;
  }
  return false;
}

Rectifier::Rectifier() = default;
Rectifier::~Rectifier() = default;

absl::StatusOr<std::shared_ptr<const Rectifier::Maps>> Rectifier::MapsFor(
    const sensor_msgs::CameraInfo& info, const std::string& info_topic) {
  {
    MutexLock lock(&mu_);
    if (maps_ != nullptr && SameCamera(info, maps_->camera)) {
      return maps_;
    }
  }
  for (size_t i = 0; i < info.D.size(); ++i) {
    if (!std::isfinite(info.D[i])) {
      return absl::InvalidArgumentError(
          absl::StrCat(info_topic, ": D[", i, "] is ", info.D[i], " (must be finite)"));
    }
  }
  for (size_t i = 0; i < info.K.size(); ++i) {
    if (!std::isfinite(info.K[i])) {
      return absl::InvalidArgumentError(
          absl::StrCat(info_topic, ": K[", i, "] is ", info.K[i], " (must be finite)"));
    }
  }
  const bool fisheye = info.distortion_model == "equidistant";
  if (info.distortion_model == "plumb_bob" || info.distortion_model == "rational_polynomial") {
    const size_t n = info.D.size();
    if (n != 4 && n != 5 && n != 8 && n != 12 && n != 14) {
      return absl::InvalidArgumentError(
          absl::StrCat(info_topic, ": D has ", n, " coefficients; ", info.distortion_model,
                       " takes 5 (k1 k2 t1 t2 k3) or 8 (... k4 k5 k6); OpenCV's 4, 12 "
                       "and 14 are read too"));
    }
  } else if (fisheye) {
    if (info.D.size() != 4) {
      return absl::InvalidArgumentError(absl::StrCat(
          info_topic, ": D has ", info.D.size(), " coefficients; equidistant takes 4 (k1..k4)"));
    }
  } else {
    return absl::InvalidArgumentError(absl::StrCat(
        info_topic, ": distortion_model \"", info.distortion_model,
        "\" with a non-zero D is not supported (plumb_bob, rational_polynomial, equidistant; "
        "or rectified images with D all zero)"));
  }
  auto maps = std::make_shared<Maps>();
  maps->camera = info;
  // The lens's own K (a skew included) in, the pinhole camera the frame names out.
  const cv::Matx33d K(info.K.data());
  const cv::Matx33d pinhole(info.K[0], 0, info.K[2], 0, info.K[4], info.K[5], 0, 0, 1);
  const cv::Mat D(info.D, /*copyData=*/true);
  const cv::Size size(int(info.width), int(info.height));
  try {
    if (fisheye) {
      cv::fisheye::initUndistortRectifyMap(K, D, cv::Matx33d::eye(), pinhole, size, CV_16SC2,
                                           maps->map1, maps->map2);
    } else {
      cv::initUndistortRectifyMap(K, D, cv::Matx33d::eye(), pinhole, size, CV_16SC2, maps->map1,
                                  maps->map2);
    }
  } catch (const cv::Exception& e) {
    return absl::InvalidArgumentError(
        absl::StrCat(info_topic, ": the distortion cannot be undone: ", e.what()));
  }
  std::shared_ptr<const Maps> built = std::move(maps);
  MutexLock lock(&mu_);
  maps_ = built;
  return built;
}

absl::Status Rectifier::Rectify(const sensor_msgs::CameraInfo& info, const std::string& info_topic,
                                const std::string& color_topic, RosFrame* frame) {
  if (!HasDistortion(info)) return absl::OkStatus();
  const int w = frame->width, h = frame->height;
  const size_t pixels = size_t(std::max(w, 0)) * size_t(std::max(h, 0));
  if (w <= 0 || h <= 0 || uint32_t(w) != info.width || uint32_t(h) != info.height ||
      frame->depth_mm.size() != pixels ||
      (frame->frame.color_encoding() == v1::COLOR_ENCODING_RAW_RGB8 &&
       frame->frame.color().size() != pixels * 3)) {
    return absl::InvalidArgumentError(absl::StrCat(info_topic, ": camera_info is for ", info.width,
                                                   "x", info.height, " images, the frame is ", w,
                                                   "x", h));
  }
  absl::StatusOr<std::shared_ptr<const Maps>> maps = MapsFor(info, info_topic);
  if (!maps.ok()) return maps.status();
  const Maps& m = **maps;
  const cv::Mat depth(h, w, CV_16UC1, frame->depth_mm.data());
  cv::Mat rectified;
  cv::remap(depth, rectified, m.map1, m.map2, cv::INTER_NEAREST, cv::BORDER_CONSTANT, 0);
  std::memcpy(frame->depth_mm.data(), rectified.data, frame->depth_mm.size() * 2);

  v1::Frame& f = frame->frame;
  if (f.color_encoding() == v1::COLOR_ENCODING_NONE) return absl::OkStatus();
  perception::ColorImage color;  // decoded colour; raw colour is remapped where it is
  uint8_t* rgb_data = reinterpret_cast<uint8_t*>(f.mutable_color()->data());
  if (f.color_encoding() != v1::COLOR_ENCODING_RAW_RGB8) {
    const auto codec = f.color_encoding() == v1::COLOR_ENCODING_JPEG ? perception::ColorCodec::kJpeg
                                                                     : perception::ColorCodec::kPng;
    absl::StatusOr<perception::ColorImage> decoded =
        perception::DecodeColor(codec, f.color(), w, h);
    if (!decoded.ok()) {
      return absl::InvalidArgumentError(absl::StrCat(
          color_topic, ": undistorting the colour image: ", decoded.status().message()));
    }
    color = *std::move(decoded);
    rgb_data = color.rgb.data();
  }
  const cv::Mat rgb(h, w, CV_8UC3, rgb_data);
  cv::Mat out;
  cv::remap(rgb, out, m.map1, m.map2, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar());
  f.set_color(reinterpret_cast<const char*>(out.data), size_t(w) * h * 3);
  f.set_color_encoding(v1::COLOR_ENCODING_RAW_RGB8);
  return absl::OkStatus();
}

}  // namespace skimap::bag
