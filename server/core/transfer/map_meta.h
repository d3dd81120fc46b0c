// The map's counters that must survive restarts but belong to no volume, stored as one
// chunk ("meta" volume, key (0, 0, 0); docs/formats.md): the next instance id (ids are
// never reused), the last instance event sequence (numbers are never reused) and the
// fingerprint of the object database the labels volume was made with.
//
// Thread safety: pure functions.
#ifndef SERVER_CORE_TRANSFER_MAP_META_H_
#define SERVER_CORE_TRANSFER_MAP_META_H_

#include <cstdint>
#include <string>
#include <string_view>

#include "absl/status/statusor.h"

namespace skimap::server {

inline constexpr char kMetaVolume[] = "meta";

struct MapMeta {
  uint64_t next_instance_id = 1;
  uint64_t last_event_sequence = 0;
  uint64_t fingerprint = 0;
  friend bool operator==(const MapMeta&, const MapMeta&) = default;
};

// A sealed chunk blob (chunk_codec.h, content kMapMeta).
std::string EncodeMapMeta(const MapMeta& meta);
// DataLoss / FailedPrecondition as OpenChunk, or for a malformed payload.
absl::StatusOr<MapMeta> DecodeMapMeta(std::string_view blob);

}  // namespace skimap::server

#endif  // SERVER_CORE_TRANSFER_MAP_META_H_
