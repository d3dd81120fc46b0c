#include "client/map_files.h"

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <opencv2/core.hpp>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "codec/image_files.h"
#include "codec/ros_map_pixel.h"

namespace skimap::client {
namespace {

absl::Status WriteFile(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  out.close();
  if (!out) return absl::InternalError(absl::StrCat("cannot write ", path));
  return absl::OkStatus();
}

std::string FileName(const std::string& path) {
  return std::filesystem::path(path).filename().string();
}

}  // namespace

std::string ReplaceExtension(const std::string& path, const std::string& ext) {
  return std::filesystem::path(path).replace_extension(ext).string();
}

absl::Status WriteRosMap(const v1::OccupancyGrid& grid, const std::string& yaml_path) {
  if (!absl::EndsWith(yaml_path, ".yaml")) {
    return absl::InvalidArgumentError("grid output must end in .yaml");
  }
  const size_t w = grid.width(), h = grid.height();
  if (grid.data().size() != w * h) {
    return absl::InvalidArgumentError("grid: data size differs from width x height");
  }
  const bool raw = grid.inflation_radius() > 0;  // a cost grid: the values themselves
  std::string pgm = absl::StrFormat("P5\n# skimap occupancy grid\n%d %d\n255\n", w, h);
  const size_t header = pgm.size();
  pgm.resize(header + w * h);
  for (size_t row = 0; row < h; ++row) {
    const size_t j = h - 1 - row;  // image top = largest y
    for (size_t i = 0; i < w; ++i) {
      const int8_t cell = static_cast<int8_t>(grid.data()[j * w + i]);
      pgm[header + row * w + i] = static_cast<char>(RosMapPixel(cell, raw));
    }
  }
  const std::string pgm_path = ReplaceExtension(yaml_path, ".pgm");
  if (absl::Status s = WriteFile(pgm_path, pgm); !s.ok()) return s;
  const std::string yaml = absl::StrFormat(
      "image: %s\nresolution: %.9g\norigin: [%.9g, %.9g, 0.0]\nnegate: 0\n"
      "occupied_thresh: 0.65\nfree_thresh: 0.196\nmode: %s\n",
      FileName(pgm_path), grid.resolution(), grid.origin_x(), grid.origin_y(),
      raw ? "raw" : "trinary");
  return WriteFile(yaml_path, yaml);
}

absl::Status WriteHeightMap(const v1::HeightMap& map, const std::string& path) {
  const bool png = absl::EndsWith(path, ".png");
  const bool tiff = absl::EndsWith(path, ".tiff") || absl::EndsWith(path, ".tif");
  if (!png && !tiff) return absl::InvalidArgumentError("height map output: .png or .tiff");
  const int w = static_cast<int>(map.width()), h = static_cast<int>(map.height());
  if (map.heights_size() != w * h || w == 0 || h == 0) {
    return absl::InvalidArgumentError("height map: empty or size differs from width x height");
  }
  float lowest = std::numeric_limits<float>::infinity();
  for (float z : map.heights()) {
    if (!std::isnan(z)) lowest = std::min(lowest, z);
  }
  // One millimetre below the lowest height, so that every known cell has v >= 1.
  const double z_offset = std::isfinite(lowest) ? std::floor(lowest * 1000.0) / 1000.0 - 0.001 : 0;
  cv::Mat image(h, w, png ? CV_16UC1 : CV_32FC1);
  for (int row = 0; row < h; ++row) {
    const int j = h - 1 - row;
    for (int i = 0; i < w; ++i) {
      const float z = map.heights(j * w + i);
      if (tiff) {
        image.at<float>(row, i) = z;
      } else {
        const double v = std::isnan(z) ? 0 : std::round((z - z_offset) * 1000.0);
        image.at<uint16_t>(row, i) = static_cast<uint16_t>(std::clamp(v, 0.0, 65535.0));
      }
    }
  }
  if (!perception::WriteImageFile(path, image).ok()) {
    return absl::InternalError(absl::StrCat("cannot write ", path));
  }
  const std::string yaml = absl::StrFormat(
      "image: %s\nresolution: %.9g\norigin: [%.9g, %.9g]\nwidth: %d\nheight: %d\n"
      "encoding: %s\nz_offset: %.9g\nz_scale: %s\nunknown: %s\nrow_order: top_is_max_y\n",
      FileName(path), map.resolution(), map.origin_x(), map.origin_y(), w, h,
      png ? "uint16_mm" : "float32_m", png ? z_offset : 0.0, png ? "0.001" : "1",
      png ? "0" : "nan");
  return WriteFile(ReplaceExtension(path, ".yaml"), yaml);
}

absl::Status WritePly(const std::vector<v1::Voxel>& voxels, const std::string& path) {
  std::string out = absl::StrFormat(
      "ply\nformat binary_little_endian 1.0\ncomment skimap voxels (centres)\n"
      "element vertex %d\nproperty float x\nproperty float y\nproperty float z\n"
      "property uchar red\nproperty uchar green\nproperty uchar blue\n"
      "property float weight\nend_header\n",
      voxels.size());
  auto put_float = [&out](float f) {
    uint32_t bits;
    std::memcpy(&bits, &f, 4);
    for (int b = 0; b < 4; ++b) out.push_back(static_cast<char>(bits >> (8 * b)));
  };
  for (const v1::Voxel& v : voxels) {
    put_float(static_cast<float>(v.center().x()));
    put_float(static_cast<float>(v.center().y()));
    put_float(static_cast<float>(v.center().z()));
    out.push_back(static_cast<char>(v.rgb() >> 16));
    out.push_back(static_cast<char>(v.rgb() >> 8));
    out.push_back(static_cast<char>(v.rgb()));
    put_float(v.weight());
  }
  return WriteFile(path, out);
}

}  // namespace skimap::client
