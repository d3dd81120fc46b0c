// The key box of a query's world box (GetVoxels, GetLabelVoxels): the voxels of `grid`
// whose centres lie in the box, bounds inclusive.
//
//   absl::StatusOr<KeyBox> keys = QueryKeyBox(volume.grid(), request.has_box(), request.box());
//
// Thread safety: a pure function.
#ifndef SERVER_MAPS_QUERY_BOX_H_
#define SERVER_MAPS_QUERY_BOX_H_

#include "absl/status/statusor.h"
#include "skimap/encoding.h"
#include "skimap/grid.h"
#include "skimap/v1/geometry.pb.h"

namespace skimap::server {

// Every key when `has_box` is false; InvalidArgument naming "box" unless the box is finite
// with min <= max on every axis. The result may be empty (no centre inside).
absl::StatusOr<KeyBox> QueryKeyBox(const Grid& grid, bool has_box, const v1::Box3& box);

// Appends the box filter (whether given, and its six bounds) to `e`, for a query's page
// token fingerprint (page_token.h).
void EncodeQueryBox(bool has_box, const v1::Box3& box, Encoder& e);

}  // namespace skimap::server

#endif  // SERVER_MAPS_QUERY_BOX_H_
