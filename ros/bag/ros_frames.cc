#include "ros/bag/ros_frames.h"

#include <cmath>
#include <cstring>

#include "absl/strings/str_cat.h"
#include "codec/image_header.h"

namespace skimap::bag {
namespace {

// Checks an Image's size, step and data length against `bytes_per_pixel`.
absl::Status CheckImage(const sensor_msgs::Image& image, const std::string& topic,
                        int bytes_per_pixel) {
  if (image.width == 0 || image.height == 0 || image.width > kMaxImageSide ||
      image.height > kMaxImageSide) {
    return absl::InvalidArgumentError(absl::StrCat(topic, ": size ", image.width, "x", image.height,
                                                   " is outside 1..", kMaxImageSide));
  }
  if (static_cast<uint64_t>(image.step) < uint64_t{image.width} * bytes_per_pixel) {
    return absl::InvalidArgumentError(absl::StrCat(topic, ": step ", image.step,
                                                   " is less than width ", image.width, " x ",
                                                   bytes_per_pixel, " bytes of ", image.encoding));
  }
  const uint64_t needed = uint64_t{image.height} * image.step;
  if (image.data.size() < needed) {
    return absl::InvalidArgumentError(absl::StrCat(topic, ": data holds ", image.data.size(),
                                                   " bytes, height ", image.height, " x step ",
                                                   image.step, " needs ", needed));
  }
  return absl::OkStatus();
}

bool HostIsBigEndian() {
  const uint16_t one = 1;
  uint8_t first;
  std::memcpy(&first, &one, 1);
  return first == 0;
}

absl::Status ConvertDepth(const sensor_msgs::Image& depth, const std::string& topic,
                          RosFrame* out) {
  const bool swap = (depth.is_bigendian != 0) != HostIsBigEndian();
  const int w = depth.width, h = depth.height;
  if (depth.encoding == "16UC1" || depth.encoding == "mono16") {
    if (absl::Status s = CheckImage(depth, topic, 2); !s.ok()) return s;
    out->depth_mm.resize(size_t(w) * h);
    for (int y = 0; y < h; ++y) {
      const uint8_t* row = depth.data.data() + size_t(y) * depth.step;
      uint16_t* dst = out->depth_mm.data() + size_t(y) * w;
      std::memcpy(dst, row, size_t(w) * 2);
      if (swap) {
        for (int x = 0; x < w; ++x) dst[x] = static_cast<uint16_t>((dst[x] >> 8) | (dst[x] << 8));
      }
    }
  } else if (depth.encoding == "32FC1") {
    if (absl::Status s = CheckImage(depth, topic, 4); !s.ok()) return s;
    out->depth_mm.resize(size_t(w) * h);
    for (int y = 0; y < h; ++y) {
      const uint8_t* row = depth.data.data() + size_t(y) * depth.step;
      for (int x = 0; x < w; ++x) {
        uint32_t bits;
        std::memcpy(&bits, row + size_t(x) * 4, 4);
        if (swap) bits = __builtin_bswap32(bits);
        float metres;
        std::memcpy(&metres, &bits, 4);
        out->depth_mm[size_t(y) * w + x] = MillimetresOf(metres);
      }
    }
  } else {
    return absl::InvalidArgumentError(
        absl::StrCat(topic, ": depth encoding \"", depth.encoding,
                     "\" is not supported (16UC1 in millimetres or 32FC1 in metres, REP 118)"));
  }
  out->width = w;
  out->height = h;
  return absl::OkStatus();
}

absl::Status ConvertRawColor(const sensor_msgs::Image& color, const std::string& topic,
                             v1::Frame* frame) {
  int channels = 0;
  bool bgr = false;
  if (color.encoding == "rgb8") {
    channels = 3;
  } else if (color.encoding == "bgr8") {
    channels = 3, bgr = true;
  } else if (color.encoding == "rgba8") {
    channels = 4;
  } else if (color.encoding == "bgra8") {
    channels = 4, bgr = true;
  } else if (color.encoding == "mono8") {
    channels = 1;
  } else {
    return absl::InvalidArgumentError(
        absl::StrCat(topic, ": colour encoding \"", color.encoding,
                     "\" is not supported (rgb8, bgr8, rgba8, bgra8, mono8, or a "
                     "sensor_msgs/CompressedImage with JPEG or PNG)"));
  }
  if (absl::Status s = CheckImage(color, topic, channels); !s.ok()) return s;
  const int w = color.width, h = color.height;
  std::string* rgb = frame->mutable_color();
  rgb->resize(size_t(w) * h * 3);
  char* dst = rgb->data();
  for (int y = 0; y < h; ++y) {
    const uint8_t* row = color.data.data() + size_t(y) * color.step;
    if (channels == 3 && !bgr) {
      std::memcpy(dst, row, size_t(w) * 3);
      dst += size_t(w) * 3;
      continue;
    }
    for (int x = 0; x < w; ++x, dst += 3) {
      const uint8_t* p = row + size_t(x) * channels;
      if (channels == 1) {
        dst[0] = dst[1] = dst[2] = static_cast<char>(p[0]);
      } else {
        dst[0] = static_cast<char>(bgr ? p[2] : p[0]);
        dst[1] = static_cast<char>(p[1]);
        dst[2] = static_cast<char>(bgr ? p[0] : p[2]);
      }
    }
  }
  frame->set_color_encoding(v1::COLOR_ENCODING_RAW_RGB8);
  return absl::OkStatus();
}

absl::Status ConvertCompressedColor(const sensor_msgs::CompressedImage& color,
                                    const std::string& topic, int width, int height,
                                    v1::Frame* frame) {
  const absl::string_view bytes(reinterpret_cast<const char*>(color.data.data()),
                                color.data.size());
  perception::ImageFormat format;
  v1::ColorEncoding encoding;
  if (bytes.size() >= 2 && uint8_t(bytes[0]) == 0xFF && uint8_t(bytes[1]) == 0xD8) {
    format = perception::ImageFormat::kJpeg, encoding = v1::COLOR_ENCODING_JPEG;
  } else if (bytes.size() >= 8 && bytes.substr(0, 8) == "\x89PNG\r\n\x1a\n") {
    format = perception::ImageFormat::kPng, encoding = v1::COLOR_ENCODING_PNG;
  } else {
    return absl::InvalidArgumentError(absl::StrCat(topic, ": compressed image (format \"",
                                                   color.format, "\") is neither JPEG nor PNG"));
  }
  absl::StatusOr<perception::ImageHeader> header =
      perception::ReadImageHeader(format, bytes, topic);
  if (!header.ok()) return header.status();
  if (header->width != width || header->height != height) {
    return absl::InvalidArgumentError(absl::StrCat(
        topic, ": colour image is ", header->width, "x", header->height, ", the depth image ",
        width, "x", height, " (register depth to colour: a depth_registered topic)"));
  }
  frame->set_color(bytes.data(), bytes.size());
  frame->set_color_encoding(encoding);
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<RosFrame> MakeRosFrame(const sensor_msgs::Image& depth,
                                      const std::string& depth_topic, const ColorMessage& color,
                                      const sensor_msgs::CameraInfo& info,
                                      const std::string& info_topic,
                                      const Eigen::Isometry3d& T_world_camera) {
  RosFrame out;
  if (absl::Status s = ConvertDepth(depth, depth_topic, &out); !s.ok()) return s;
  if (info.width != depth.width || info.height != depth.height) {
    return absl::InvalidArgumentError(absl::StrCat(info_topic, ": camera_info is for ", info.width,
                                                   "x", info.height, " images, ", depth_topic,
                                                   " is ", depth.width, "x", depth.height));
  }
  const double fx = info.K[0], fy = info.K[4], cx = info.K[2], cy = info.K[5];
  if (!(fx > 0) || !(fy > 0) || !std::isfinite(fx) || !std::isfinite(fy) || !std::isfinite(cx) ||
      !std::isfinite(cy)) {
    return absl::InvalidArgumentError(
        absl::StrCat(info_topic, ": K has focal lengths ", fx, ", ", fy, " (must be > 0)"));
  }
  v1::Frame& f = out.frame;
  if (color.image != nullptr) {
    if (color.image->width != depth.width || color.image->height != depth.height) {
      return absl::InvalidArgumentError(
          absl::StrCat(color.topic, ": colour image is ", color.image->width, "x",
                       color.image->height, ", the depth image ", depth.width, "x", depth.height,
                       " (register depth to colour: a depth_registered topic)"));
    }
    if (absl::Status s = ConvertRawColor(*color.image, color.topic, &f); !s.ok()) return s;
  } else if (color.compressed != nullptr) {
    if (absl::Status s =
            ConvertCompressedColor(*color.compressed, color.topic, depth.width, depth.height, &f);
        !s.ok()) {
      return s;
    }
  }
  f.mutable_timestamp()->set_seconds(depth.header.stamp.sec);
  f.mutable_timestamp()->set_nanos(static_cast<int32_t>(depth.header.stamp.nsec));
  const Eigen::Quaterniond q(T_world_camera.rotation());
  const Eigen::Vector3d t = T_world_camera.translation();
  v1::Pose* pose = f.mutable_pose();
  pose->mutable_rotation()->set_w(q.w());
  pose->mutable_rotation()->set_x(q.x());
  pose->mutable_rotation()->set_y(q.y());
  pose->mutable_rotation()->set_z(q.z());
  pose->mutable_translation()->set_x(t.x());
  pose->mutable_translation()->set_y(t.y());
  pose->mutable_translation()->set_z(t.z());
  v1::CameraIntrinsics* K = f.mutable_intrinsics();
  K->set_fx(fx);
  K->set_fy(fy);
  K->set_cx(cx);
  K->set_cy(cy);
  K->set_width(depth.width);
  K->set_height(depth.height);
  f.set_depth_scale(0.001);
  return out;
}

}  // namespace skimap::bag
