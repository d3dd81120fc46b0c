#include "server/core/maps/map_config.h"

#include <cmath>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "base/echo.h"

namespace skimap::server {
namespace {

absl::Status BadMapOption(absl::string_view field, absl::string_view what) {
  return absl::InvalidArgumentError(absl::StrCat("options.", field, " ", what));
}

}  // namespace

absl::StatusOr<MapConfig> ResolveMapOptions(const v1::MapOptions& o) {
  MapConfig c;
  if (o.has_resolution()) c.resolution = o.resolution();
  if (!(c.resolution >= 0.001 && c.resolution <= 10)) {
    return BadMapOption("resolution", "must be in [0.001, 10] metres");
  }
  if (o.has_min_depth()) c.integration.min_depth = o.min_depth();
  if (o.has_max_depth()) c.integration.max_depth = o.max_depth();
  if (o.has_pixel_stride()) c.integration.pixel_stride = static_cast<int>(o.pixel_stride());
  if (!(c.integration.min_depth >= 0) || !std::isfinite(c.integration.min_depth)) {
    return BadMapOption("min_depth", "must be finite and >= 0");
  }
  if (!(c.integration.max_depth > c.integration.min_depth) ||
      !std::isfinite(c.integration.max_depth)) {
    return BadMapOption("max_depth", "must be finite and > min_depth");
  }
  if (o.has_pixel_stride() && (o.pixel_stride() < 1 || o.pixel_stride() > 64)) {
    return BadMapOption("pixel_stride", "must be in 1..64");
  }
  if (o.has_depth_edge_jump()) {
    if (!(o.depth_edge_jump() >= 0 && o.depth_edge_jump() <= 1)) {
      return BadMapOption("depth_edge_jump", "must be in [0, 1]");
    }
    c.integration.depth_edge_jump = o.depth_edge_jump();
  }
  if (o.has_min_voxel_weight()) c.min_voxel_weight = o.min_voxel_weight();
  if (!(c.min_voxel_weight >= 0) || !std::isfinite(c.min_voxel_weight)) {
    return BadMapOption("min_voxel_weight", "must be finite and >= 0");
  }
  if (o.has_band_min_z()) c.band_min_z = o.band_min_z();
  if (o.has_band_max_z()) c.band_max_z = o.band_max_z();
  if (o.has_floor_min_z()) c.floor_min_z = o.floor_min_z();
  if (!std::isfinite(c.band_min_z) || !std::isfinite(c.band_max_z) ||
      !std::isfinite(c.floor_min_z) || !(c.floor_min_z <= c.band_min_z) ||
      !(c.band_min_z <= c.band_max_z)) {
    return BadMapOption("band_min_z", "band: need finite floor_min_z <= band_min_z <= band_max_z");
  }
  if (o.has_carve_free_space()) c.carve_free_space = o.carve_free_space();
  if (o.has_carve_pixel_stride()) {
    if (o.carve_pixel_stride() < 1 || o.carve_pixel_stride() > 64) {
      return BadMapOption("carve_pixel_stride", "must be in 1..64");
    }
    c.carve_pixel_stride = static_cast<int>(o.carve_pixel_stride());
  }
  if (o.has_recognition()) {
    absl::StatusOr<RecognitionConfig> r = ResolveRecognitionOptions(o.recognition());
    if (!r.ok()) return r.status();
    c.recognition = *std::move(r);
  }
  return c;
}

absl::StatusOr<MapConfig> ResolveStoredMapOptions(v1::MapOptions o) {
  // Written before depth_edge_jump existed: its frames were integrated without the filter.
  if (!o.has_depth_edge_jump()) o.set_depth_edge_jump(0);
  return ResolveMapOptions(o);
}

v1::MapOptions ToProto(const MapConfig& c) {
  v1::MapOptions o;
  o.set_resolution(c.resolution);
  o.set_min_depth(c.integration.min_depth);
  o.set_max_depth(c.integration.max_depth);
  o.set_pixel_stride(c.integration.pixel_stride);
  o.set_depth_edge_jump(c.integration.depth_edge_jump);
  o.set_min_voxel_weight(c.min_voxel_weight);
  o.set_band_min_z(c.band_min_z);
  o.set_band_max_z(c.band_max_z);
  o.set_floor_min_z(c.floor_min_z);
  o.set_carve_free_space(c.carve_free_space);
  o.set_carve_pixel_stride(c.carve_pixel_stride);
  if (c.recognition.enabled) *o.mutable_recognition() = ToProto(c.recognition);
  return o;
}

absl::Status ValidateMapId(absl::string_view id, absl::string_view field) {
  bool ok = !id.empty() && id.size() <= 63 && id[0] >= 'a' && id[0] <= 'z';
  for (char ch : id) {
    ok = ok && ((ch >= 'a' && ch <= 'z') || (ch >= '0' && ch <= '9') || ch == '-' || ch == '_');
  }
  if (ok) return absl::OkStatus();
  return absl::InvalidArgumentError(absl::StrCat(
      field, " must be 1-63 characters of [a-z0-9_-] starting with a letter, got ", Echo(id)));
}

absl::StatusOr<std::string> ParseMapName(absl::string_view name, absl::string_view field) {
  if (!absl::StartsWith(name, "maps/")) {
    return absl::InvalidArgumentError(
        absl::StrCat(field, " must be \"maps/{map_id}\", got ", Echo(name)));
  }
  absl::string_view id = name.substr(5);
  if (absl::Status s = ValidateMapId(id, field); !s.ok()) return s;
  return std::string(id);
}

double MaxCameraExtent(const MapConfig& config) {
  return kMaxKey * config.resolution - config.integration.max_depth;
}

absl::Status ValidatePoseInMap(const perception::CameraPose& pose, const MapConfig& config,
                               absl::string_view field) {
  const double extent = MaxCameraExtent(config);
  if ((pose.translation.array().abs() <= extent).all()) return absl::OkStatus();
  return absl::InvalidArgumentError(
      absl::StrCat(field, ".translation: (", pose.translation.x(), ", ", pose.translation.y(), ", ",
                   pose.translation.z(), ") m is outside this map's extent of +-", extent,
                   " m per axis (2^20 voxels of ", config.resolution, " m, less max_depth)"));
}

std::string MapName(absl::string_view map_id) { return absl::StrCat("maps/", map_id); }

}  // namespace skimap::server
