// Map options from the command line: `skimap maps create ID`, `skimap stream` and
// `skimap eval` take the MapOptions fields (skimap/v1/maps.proto) as flags of the same
// names, for the maps they create:
//
//   --min_depth --max_depth --min_voxel_weight --band_min_z --band_max_z --floor_min_z
//   --pixel_stride --depth_edge_jump --carve_free_space=true|false --carve_pixel_stride
//   (and --resolution, in main)
//
// Only the flags given on the command line are set; the server fills in the rest and
// validates, so a bad value gets the API's own message ("options.band_min_z ..."). A
// stream into an existing map cannot change its options: a given flag that disagrees with
// the map is an error naming it.
//
// Thread safety: reads the process's flags; call after absl::ParseCommandLine.
#ifndef CLIENT_CLI_MAP_OPTION_FLAGS_H_
#define CLIENT_CLI_MAP_OPTION_FLAGS_H_

#include <string>

#include "absl/status/status.h"
#include "skimap/v1/maps.pb.h"

namespace skimap::client {

// Sets the fields of *options whose flags were given; InvalidArgument naming the flag when
// a value does not parse (a number, an integer, true or false).
absl::Status ApplyMapOptionFlags(v1::MapOptions* options);

// OK when every scalar field set in `wanted` (ApplyMapOptionFlags' output) equals
// `existing`'s value (the options of the existing map `map_name`); FailedPrecondition
// naming the first flag that does not.
absl::Status CheckMapOptions(const v1::MapOptions& wanted, const v1::MapOptions& existing,
                             const std::string& map_name);

}  // namespace skimap::client

#endif  // CLIENT_CLI_MAP_OPTION_FLAGS_H_
