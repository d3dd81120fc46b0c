// Test data for ros/: the real YCB-Video frames of ../shared/data/ycbv-0000 as ROS messages
// and, independently of ros/bag's conversion, as the API frames they must become.
//
// Depth in ROS is millimetres (16UC1, REP 118) while the BOP files hold 0.1 mm: both sides
// use the depth rounded to millimetres, so "the same frames" is exact. Camera frames:
// world -> camera_link (per frame, /tf) -> camera_color_optical_frame (/tf_static, the
// usual optical rotation), composed = the BOP pose. Stamps: 1000 s + frame index / 30.
//
// Thread safety: plain functions and values.
#ifndef TESTS_ROS_ROS_TEST_DATA_H_
#define TESTS_ROS_ROS_TEST_DATA_H_

#include <geometry_msgs/TransformStamped.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>
#include <tf2_msgs/TFMessage.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstring>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "codec/rvl_codec.h"
#include "dataset/reader.h"
#include "skimap/v1/frames.pb.h"
#include "tests/common/images.h"

namespace skimap::testing {

inline constexpr char kOpticalFrame[] = "camera_color_optical_frame";

struct MmFrame {
  int index = 0;
  ros::Time stamp;
  int width = 0, height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;
  std::vector<uint16_t> depth_mm;
  std::vector<uint8_t> rgb;  // R G B
  Eigen::Isometry3d T_wc = Eigen::Isometry3d::Identity();
};

// camera_link <- optical frame: z forward = link x, x right = -link y, y down = -link z.
inline Eigen::Isometry3d LinkFromOptical() {
  Eigen::Matrix3d R;
  R << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = R;
  T.translation() = Eigen::Vector3d(0.01, 0.02, -0.03);
  return T;
}

inline std::vector<MmFrame> LoadMmFrames(const std::string& dir) {
  std::vector<MmFrame> out;
  absl::StatusOr<dataset::Sequence> seq = dataset::LoadSequence(dir);
  if (!seq.ok()) return out;
  for (size_t i = 0; i < seq->frames.size(); ++i) {
    const dataset::Frame& f = seq->frames[i];
    MmFrame m;
    m.index = static_cast<int>(i);
    m.stamp = ros::Time(1000.0 + i / 30.0);
    cv::Mat depth = ImRead(f.depth_path, ImageMode::kAnyDepth);
    cv::Mat bgr = ImRead(f.rgb_path, ImageMode::kColor);
    m.width = depth.cols;
    m.height = depth.rows;
    m.depth_mm.resize(size_t(m.width) * m.height);
    for (int y = 0; y < m.height; ++y) {
      for (int x = 0; x < m.width; ++x) {
        m.depth_mm[size_t(y) * m.width + x] =
            static_cast<uint16_t>(std::lround(depth.at<uint16_t>(y, x) * f.depth_scale));
      }
    }
    cv::Mat rgb;
    cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
    m.rgb.assign(rgb.data, rgb.data + rgb.total() * 3);
    m.fx = f.K.fx, m.fy = f.K.fy, m.cx = f.K.cx, m.cy = f.K.cy;
    // The pose as a rigid transform (BOP's rotation, read from text, is orthonormal only
    // to ~1e-8): tf composes quaternions, so both sides must start from the same rotation.
    m.T_wc.linear() = Eigen::Quaterniond(f.T_wc.rotation()).normalized().toRotationMatrix();
    m.T_wc.translation() = f.T_wc.translation();
    out.push_back(std::move(m));
  }
  return out;
}

// The API frame `f` must become (RAW_U16 mm depth, RAW_RGB8 colour).
inline v1::Frame ReferenceFrame(const MmFrame& f, const std::string& map, uint64_t sequence) {
  v1::Frame out;
  out.set_map(map);
  out.set_sequence(sequence);
  out.mutable_timestamp()->set_seconds(f.stamp.sec);
  out.mutable_timestamp()->set_nanos(f.stamp.nsec);
  const Eigen::Quaterniond q(f.T_wc.rotation());
  out.mutable_pose()->mutable_rotation()->set_w(q.w());
  out.mutable_pose()->mutable_rotation()->set_x(q.x());
  out.mutable_pose()->mutable_rotation()->set_y(q.y());
  out.mutable_pose()->mutable_rotation()->set_z(q.z());
  out.mutable_pose()->mutable_translation()->set_x(f.T_wc.translation().x());
  out.mutable_pose()->mutable_translation()->set_y(f.T_wc.translation().y());
  out.mutable_pose()->mutable_translation()->set_z(f.T_wc.translation().z());
  v1::CameraIntrinsics* K = out.mutable_intrinsics();
  K->set_fx(f.fx), K->set_fy(f.fy), K->set_cx(f.cx), K->set_cy(f.cy);
  K->set_width(f.width), K->set_height(f.height);
  out.set_depth_encoding(v1::DEPTH_ENCODING_RAW_U16);
  out.set_depth(reinterpret_cast<const char*>(f.depth_mm.data()), f.depth_mm.size() * 2);
  out.set_depth_scale(0.001);
  out.set_color_encoding(v1::COLOR_ENCODING_RAW_RGB8);
  out.set_color(reinterpret_cast<const char*>(f.rgb.data()), f.rgb.size());
  return out;
}

inline sensor_msgs::Image DepthMessage(const MmFrame& f) {
  sensor_msgs::Image m;
  m.header.stamp = f.stamp;
  m.header.frame_id = kOpticalFrame;
  m.width = f.width, m.height = f.height;
  m.encoding = "16UC1";
  m.step = f.width * 2;
  m.data.resize(f.depth_mm.size() * 2);
  std::memcpy(m.data.data(), f.depth_mm.data(), m.data.size());
  return m;
}

inline sensor_msgs::Image ColorMessage(const MmFrame& f) {
  sensor_msgs::Image m;
  m.header.stamp = f.stamp;
  m.header.frame_id = kOpticalFrame;
  m.width = f.width, m.height = f.height;
  m.encoding = "rgb8";
  m.step = f.width * 3;
  m.data = f.rgb;
  return m;
}

// The colour as image_transport's compressed transport publishes it: JPEG at the plugin's
// default quality (80), format "rgb8; jpeg compressed bgr8".
inline sensor_msgs::CompressedImage CompressedColorMessage(const MmFrame& f) {
  sensor_msgs::CompressedImage m;
  m.header.stamp = f.stamp;
  m.header.frame_id = kOpticalFrame;
  m.format = "rgb8; jpeg compressed bgr8";
  cv::Mat rgb(f.height, f.width, CV_8UC3, const_cast<uint8_t*>(f.rgb.data()));
  cv::Mat bgr;
  cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
  std::vector<uint8_t> jpeg;
  ImEncode(".jpg", bgr, &jpeg, {.jpeg_quality = 80});
  m.data = std::move(jpeg);
  return m;
}

// The depth as image_transport's compressedDepth transport publishes it (its format as
// ros/bag/compressed_depth.h describes it, written here with OpenCV's PNG and our RVL):
// 16UC1 millimetres with `codec` "png" or "rvl"; with `metres`, 32FC1 as quantised
// inverse depth (the plugin's defaults: depth_max 10 m, depth_quantization 100).
inline sensor_msgs::CompressedImage CompressedDepthMessage(const MmFrame& f,
                                                           const std::string& codec,
                                                           bool metres = false) {
  sensor_msgs::CompressedImage m;
  m.header = DepthMessage(f).header;
  m.format = absl::StrCat(metres ? "32FC1" : "16UC1", "; compressedDepth ", codec);
  std::vector<uint16_t> pixels = f.depth_mm;
  float a = 0, b = 0;
  if (metres) {
    a = 100.0f * 101.0f;
    b = 1.0f - a / 10.0f;
    for (uint16_t& p : pixels) {
      // As the plugin: the float inverse depth truncated to uint16; no measurement: 0.
      p = p == 0 ? 0 : static_cast<uint16_t>(a / (p / 1000.0f) + b);
    }
  }
  const int32_t format = 0;
  m.data.resize(12);
  std::memcpy(m.data.data(), &format, 4);
  std::memcpy(m.data.data() + 4, &a, 4);
  std::memcpy(m.data.data() + 8, &b, 4);
  if (codec == "rvl") {
    const uint32_t size[2] = {uint32_t(f.width), uint32_t(f.height)};
    const auto* p = reinterpret_cast<const uint8_t*>(size);
    m.data.insert(m.data.end(), p, p + 8);
    const std::string rvl = perception::EncodeRvl(pixels.data(), pixels.size());
    m.data.insert(m.data.end(), rvl.begin(), rvl.end());
  } else {
    cv::Mat image(f.height, f.width, CV_16UC1, pixels.data());
    std::vector<uint8_t> png;
    ImEncode(".png", image, &png);
    m.data.insert(m.data.end(), png.begin(), png.end());
  }
  return m;
}

// A wide-angle lens's barrel distortion (plumb_bob): up to ~25 pixels at the corners of the
// 640x480 frames.
inline std::vector<double> LensDistortion() { return {-0.28, 0.07, 0.002, -0.001, 0}; }

// `f` as a camera with distortion D (OpenCV's pinhole model, or with `fisheye` its
// equidistant one) would have seen it: each distorted pixel takes the depth and colour of
// the pixel its ray meets in `f` (nearest; outside `f`: none, black).
inline MmFrame Distorted(const MmFrame& f, const std::vector<double>& D = LensDistortion(),
                         bool fisheye = false) {
  const cv::Matx33d K(f.fx, 0, f.cx, 0, f.fy, f.cy, 0, 0, 1);
  std::vector<cv::Point2f> pixels, rays;
  for (int y = 0; y < f.height; ++y) {
    for (int x = 0; x < f.width; ++x) pixels.emplace_back(float(x), float(y));
  }
  if (fisheye) {
    cv::fisheye::undistortPoints(pixels, rays, K, D, cv::noArray(), K);
  } else {
    cv::undistortPoints(pixels, rays, K, D, cv::noArray(), K);
  }
  cv::Mat map_x(f.height, f.width, CV_32FC1), map_y(f.height, f.width, CV_32FC1);
  for (int i = 0; i < f.width * f.height; ++i) {
    map_x.at<float>(i / f.width, i % f.width) = rays[i].x;
    map_y.at<float>(i / f.width, i % f.width) = rays[i].y;
  }
  MmFrame out = f;
  cv::Mat depth(f.height, f.width, CV_16UC1, const_cast<uint16_t*>(f.depth_mm.data()));
  cv::Mat rgb(f.height, f.width, CV_8UC3, const_cast<uint8_t*>(f.rgb.data()));
  cv::Mat depth_out(f.height, f.width, CV_16UC1, out.depth_mm.data());
  cv::Mat rgb_out(f.height, f.width, CV_8UC3, out.rgb.data());
  cv::remap(depth, depth_out, map_x, map_y, cv::INTER_NEAREST, cv::BORDER_CONSTANT, 0);
  cv::remap(rgb, rgb_out, map_x, map_y, cv::INTER_NEAREST, cv::BORDER_CONSTANT, cv::Scalar());
  return out;
}

inline sensor_msgs::CameraInfo InfoMessage(const MmFrame& f) {
  sensor_msgs::CameraInfo m;
  m.header.stamp = f.stamp;
  m.header.frame_id = kOpticalFrame;
  m.width = f.width, m.height = f.height;
  m.distortion_model = "plumb_bob";
  m.D.assign(5, 0.0);
  m.K = {f.fx, 0, f.cx, 0, f.fy, f.cy, 0, 0, 1};
  m.R = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  m.P = {f.fx, 0, f.cx, 0, 0, f.fy, f.cy, 0, 0, 0, 1, 0};
  return m;
}

inline geometry_msgs::TransformStamped Transform(const Eigen::Isometry3d& T,
                                                 const std::string& parent,
                                                 const std::string& child, const ros::Time& stamp) {
  geometry_msgs::TransformStamped t;
  t.header.stamp = stamp;
  t.header.frame_id = parent;
  t.child_frame_id = child;
  const Eigen::Quaterniond q(T.rotation());
  t.transform.rotation.w = q.w(), t.transform.rotation.x = q.x();
  t.transform.rotation.y = q.y(), t.transform.rotation.z = q.z();
  t.transform.translation.x = T.translation().x();
  t.transform.translation.y = T.translation().y();
  t.transform.translation.z = T.translation().z();
  return t;
}

// world <- camera_link at the frame's stamp (/tf).
inline tf2_msgs::TFMessage WorldToLink(const MmFrame& f) {
  tf2_msgs::TFMessage m;
  m.transforms.push_back(
      Transform(f.T_wc * LinkFromOptical().inverse(), "world", "camera_link", f.stamp));
  return m;
}

// camera_link <- optical (/tf_static).
inline tf2_msgs::TFMessage LinkToOptical() {
  tf2_msgs::TFMessage m;
  m.transforms.push_back(
      Transform(LinkFromOptical(), "camera_link", kOpticalFrame, ros::Time(1000.0)));
  return m;
}

}  // namespace skimap::testing

#endif  // TESTS_ROS_ROS_TEST_DATA_H_
