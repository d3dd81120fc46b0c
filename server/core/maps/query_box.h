// The key box of a query's world box (GetVoxels, GetLabelVoxels): the voxels of `grid`
// whose centres lie in the box, bounds inclusive; and the paged walk over such a box.
//
//   absl::StatusOr<KeyBox> keys = QueryKeyBox(volume.grid(), request.has_box(), request.box());
//   std::optional<VoxelKey> next = WalkBoxPage(volume, *keys, start, [&](k, v) {
//     if (page_is_full) return false;   // stop before k: the next page starts there
//     ... add k ...; return true;
//   });
//
// Thread safety: pure functions (the walk reads `volume`: hold the map's read lock).
#ifndef SERVER_CORE_MAPS_QUERY_BOX_H_
#define SERVER_CORE_MAPS_QUERY_BOX_H_

#include <algorithm>
#include <cstdint>
#include <optional>
#include <string>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "base/encoding.h"
#include "skimap/grid.h"
#include "skimap/v1/geometry.pb.h"

namespace skimap::server {

// Every key when `has_box` is false; InvalidArgument naming "box" unless the box is finite
// with min <= max on every axis. The result may be empty (no centre inside).
absl::StatusOr<KeyBox> QueryKeyBox(const Grid& grid, bool has_box, const v1::Box3& box);

// Appends the box filter (whether given, and its six bounds) to `e`, for a query's page
// token fingerprint (page_token.h).
void EncodeQueryBox(bool has_box, const v1::Box3& box, Encoder& e);

// Page tokens of the key-ordered queries, whose position is a packed voxel key.
// DecodeKeyPageToken: nullopt for "" (the first page); page_token.h's errors, or
// InvalidArgument "page_token: not a <rpc> position" for a position that is no key.
absl::StatusOr<std::optional<uint64_t>> DecodeKeyPageToken(const std::string& token, uint32_t query,
                                                           absl::string_view rpc);
std::string KeyPageToken(uint32_t query, uint64_t packed);

// Walks the voxels of `volume` (a SkiMap volume) inside `box` in slabs of 16 x keys, so
// that a full page stops the walk early instead of visiting the whole box, from the slab
// of `start` (a page token's position; nullopt: from the first key) and skipping keys whose
// PackKey is below it. `bounds`: the volume's Bounds() (the walk stays within them in x).
// visit(key, voxel) returns false when the page is full at `key` (not taken): the walk
// stops and returns that key, where the next page starts. nullopt: the box is done.
template <class Volume, class Visit>
std::optional<VoxelKey> WalkBoxPage(const Volume& volume, KeyBox box, const KeyBox& bounds,
                                    std::optional<uint64_t> start, Visit&& visit) {
  constexpr int32_t kSlab = 16;
  box.min.x = std::max({box.min.x, bounds.min.x, start ? UnpackKey(*start).x : kMinKey});
  box.max.x = std::min(box.max.x, bounds.max.x);
  std::optional<VoxelKey> next;
  for (int32_t x0 = box.min.x; x0 <= box.max.x && !next; x0 += kSlab) {
    KeyBox slab = box;
    slab.min.x = x0;
    slab.max.x = std::min<int64_t>(int64_t{x0} + kSlab - 1, box.max.x);
    volume.ForEachInBox(slab, [&](const VoxelKey& k, const auto& voxel) {
      if (next || (start && PackKey(k) < *start)) return;
      if (!visit(k, voxel)) next = k;
    });
  }
  return next;
}

}  // namespace skimap::server

#endif  // SERVER_CORE_MAPS_QUERY_BOX_H_
