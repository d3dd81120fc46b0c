// MapConfig: the effective, validated options of one map (MapOptions with defaults filled),
// and the resource-name helpers of the API ("maps/{map_id}").
//
// Thread safety: plain values and pure functions.
#ifndef SERVER_CORE_MAPS_MAP_CONFIG_H_
#define SERVER_CORE_MAPS_MAP_CONFIG_H_

#include <string>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "perception/frame_integrator.h"
#include "perception/free_space.h"
#include "server/core/recognition/recognition_config.h"
#include "skimap/map_queries.h"
#include "skimap/v1/maps.pb.h"

namespace skimap::server {

struct MapConfig {
  double resolution = 0.05;  // metres
  perception::IntegrationOptions integration;
  float min_voxel_weight = 1;                                      // queries ignore lighter voxels
  double band_min_z = 0.05, band_max_z = 1.5, floor_min_z = -0.3;  // occupancy grid band
  bool carve_free_space = true;  // free-space carving (MapOptions.carve_free_space)
  int carve_pixel_stride = 4;
  RecognitionConfig recognition;  // MapOptions.recognition (recognition_config.h)
  // The carving parameters as perception takes them (the slab is the grid band).
  perception::FreeSpaceOptions FreeSpace() const {
    return {.pixel_stride = carve_pixel_stride, .min_z = band_min_z, .max_z = band_max_z};
  }
};

// Fills the defaults of absent fields and validates. InvalidArgument naming the field
// ("options.resolution must be in [0.001, 10]").
absl::StatusOr<MapConfig> ResolveMapOptions(const v1::MapOptions& options);
// ResolveMapOptions for options a store or an export file holds (written by ToProto, every
// field of its time set): a field added since takes the value that reproduces how the map's
// frames were integrated (depth_edge_jump 0), not today's default.
absl::StatusOr<MapConfig> ResolveStoredMapOptions(v1::MapOptions options);
// The options message with every field set, as GetMap returns it.
v1::MapOptions ToProto(const MapConfig& config);

// Half the extent a camera may be placed at in a map of this config, metres per axis: the
// map's key range (2^20 voxels each way of the origin) less max_depth, so that every point
// a frame can see has a key (±10.48 km at 1 cm, ±52.4 km at 5 cm, less 5 m by default).
double MaxCameraExtent(const MapConfig& config);
// OK if the camera position lies within ±MaxCameraExtent on every axis; InvalidArgument
// "<field>.translation: ..." otherwise. `field` is "pose" or "updates[i].pose".
absl::Status ValidatePoseInMap(const perception::CameraPose& pose, const MapConfig& config,
                               absl::string_view field);

// OK if `map_id` is 1-63 characters of [a-z0-9_-] starting with a letter; InvalidArgument
// naming `field` otherwise.
absl::Status ValidateMapId(absl::string_view map_id, absl::string_view field);
// "maps/{map_id}" -> map_id; InvalidArgument naming `field` for anything else.
absl::StatusOr<std::string> ParseMapName(absl::string_view name, absl::string_view field);
std::string MapName(absl::string_view map_id);

}  // namespace skimap::server

#endif  // SERVER_CORE_MAPS_MAP_CONFIG_H_
