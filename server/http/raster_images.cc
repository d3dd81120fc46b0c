#include "server/http/raster_images.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/core.hpp>
#include <vector>

#include "absl/strings/str_cat.h"
#include "codec/image_files.h"
#include "codec/ros_map_pixel.h"

namespace skimap::server {
namespace {

absl::Status CheckRaster(uint32_t width, uint32_t height, size_t cells, const char* what) {
  if (width == 0 || height == 0) {
    return absl::FailedPreconditionError(absl::StrCat(
        what, " has no cells (an empty map or region): no image to draw; ask for JSON"));
  }
  if (cells != size_t{width} * height) {
    return absl::InvalidArgumentError(
        absl::StrCat(what, ": data size differs from width x height"));
  }
  return absl::OkStatus();
}

absl::StatusOr<std::string> Encode(const cv::Mat& image, const char* extension) {
  absl::StatusOr<std::string> bytes = perception::EncodeImage(extension, image);
  if (!bytes.ok()) {
    return absl::InternalError(absl::StrCat("cannot encode the image as ", extension));
  }
  return bytes;
}

}  // namespace

absl::StatusOr<std::string> EncodeOccupancyGrid(const v1::OccupancyGrid& grid,
                                                RasterFormat format) {
  const int w = static_cast<int>(grid.width()), h = static_cast<int>(grid.height());
  if (absl::Status s = CheckRaster(grid.width(), grid.height(), grid.data().size(), "grid");
      !s.ok()) {
    return s;
  }
  cv::Mat image(h, w, CV_8UC1);
  for (int row = 0; row < h; ++row) {
    const int j = h - 1 - row;  // image top = largest y
    for (int i = 0; i < w; ++i) {
      const int8_t cell = static_cast<int8_t>(grid.data()[size_t(j) * w + i]);
      image.at<uint8_t>(row, i) = RosMapPixel(cell, grid.inflation_radius() > 0);
    }
  }
  return Encode(image, format == RasterFormat::kPgm ? ".pgm" : ".png");
}

absl::StatusOr<std::string> EncodeHeightMapPng(const v1::HeightMap& map, double* z_offset) {
  const int w = static_cast<int>(map.width()), h = static_cast<int>(map.height());
  if (absl::Status s = CheckRaster(map.width(), map.height(), map.heights_size(), "height map");
      !s.ok()) {
    return s;
  }
  float lowest = std::numeric_limits<float>::infinity();
  for (float z : map.heights()) {
    if (!std::isnan(z)) lowest = std::min(lowest, z);
  }
  *z_offset = std::isfinite(lowest) ? std::floor(lowest * 1000.0) / 1000.0 - 0.001 : 0;
  cv::Mat image(h, w, CV_16UC1);
  for (int row = 0; row < h; ++row) {
    const int j = h - 1 - row;
    for (int i = 0; i < w; ++i) {
      const float z = map.heights(j * w + i);
      const double v = std::isnan(z) ? 0 : std::round((z - *z_offset) * 1000.0);
      image.at<uint16_t>(row, i) = static_cast<uint16_t>(std::clamp(v, 0.0, 65535.0));
    }
  }
  return Encode(image, ".png");
}

}  // namespace skimap::server
