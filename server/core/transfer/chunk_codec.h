// Chunk blobs: how the server stores a piece of a map in the MapStore (docs/formats.md,
// "Snapshot chunks"). Every blob is self-describing and checked:
//
//   "SKCK" | u16 format version | u8 codec (0 raw, 1 zstd) | u8 content | u32 voxel type
//   | u32 item count | u32 raw size | payload | u32 CRC-32C of everything before it
//
//   std::string blob = SealChunk(ChunkContent::kVoxels, V::kTypeId, count, std::move(raw));
//   absl::StatusOr<OpenedChunk> c = OpenChunk(blob, ChunkContent::kVoxels, V::kTypeId);
//
// Voxel chunks hold the voxels of one 32×32×32 block of keys of one volume: keys as three
// byte planes of local coordinates (x, y, z in 0..31, sorted by key), then the voxels'
// little-endian encodings (voxel.h Encode), zstd-compressed when that is smaller.
//
// OpenChunk validates before trusting: magic, version (a newer one is FailedPrecondition
// naming both versions), codec, content, type, sizes, CRC (DataLoss).
//
// Thread safety: pure functions.
#ifndef SERVER_CORE_TRANSFER_CHUNK_CODEC_H_
#define SERVER_CORE_TRANSFER_CHUNK_CODEC_H_

#include <bitset>
#include <cstdint>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "base/encoding.h"
#include "skimap/grid.h"
#include "skimap/voxel_batch.h"

namespace skimap::server {

inline constexpr uint16_t kChunkFormatVersion = 1;
inline constexpr int kChunkShift = 5;  // a voxel chunk spans 32 keys per axis

enum class ChunkContent : uint8_t {
  kVoxels = 1,      // voxels of one block of one volume
  kFrameIndex = 2,  // entries of the map's frame index (frame_index.h)
  kMapMeta = 3,     // the map's counters (map_meta.h)
};
// OpenChunk's `type` that accepts any stored type (the caller dispatches on it).
inline constexpr uint32_t kAnyChunkType = 0xffffffffu;

struct ChunkCoord {
  int32_t x = 0, y = 0, z = 0;
  bool operator==(const ChunkCoord&) const = default;
  template <class H>
  friend H AbslHashValue(H h, const ChunkCoord& c) {
    return H::combine(std::move(h), c.x, c.y, c.z);
  }
};

inline ChunkCoord ChunkOf(const VoxelKey& k) {
  return {k.x >> kChunkShift, k.y >> kChunkShift, k.z >> kChunkShift};
}
// The keys of chunk `c`.
inline KeyBox ChunkBox(const ChunkCoord& c) {
  constexpr int32_t kSpan = 1 << kChunkShift;
  KeyBox box;
  box.min = {c.x * kSpan, c.y * kSpan, c.z * kSpan};
  box.max = {box.min.x + kSpan - 1, box.min.y + kSpan - 1, box.min.z + kSpan - 1};
  return box;
}

struct OpenedChunk {
  uint32_t type = 0;   // the stored voxel / entry type
  uint32_t count = 0;  // items
  std::string raw;     // the uncompressed payload
};

// Wraps `raw` (count items of `content`/`type`) into a blob.
std::string SealChunk(ChunkContent content, uint32_t type, uint32_t count, std::string raw);
// Checks and unwraps a blob of the expected content and type.
absl::StatusOr<OpenedChunk> OpenChunk(std::string_view blob, ChunkContent content, uint32_t type);

// Encodes the voxels of chunk `c` (REQUIRES: keys in c, sorted, unique) into a blob.
template <Voxel V>
std::string EncodeVoxelChunk(const ChunkCoord& c,
                             const std::vector<typename VoxelBatch<V>::Item>& voxels) {
  const KeyBox box = ChunkBox(c);
  const size_t n = voxels.size();
  std::string raw(3 * n, '\0');
  for (size_t i = 0; i < n; ++i) {
    raw[i] = static_cast<char>(voxels[i].key.x - box.min.x);
    raw[n + i] = static_cast<char>(voxels[i].key.y - box.min.y);
    raw[2 * n + i] = static_cast<char>(voxels[i].key.z - box.min.z);
  }
  Encoder e(&raw);
  for (const auto& v : voxels) v.data.Encode(e);
  return SealChunk(ChunkContent::kVoxels, V::kTypeId, static_cast<uint32_t>(n), std::move(raw));
}

namespace internal {

// The voxels of an opened chunk of type V, each passed to add(key, voxel).
template <Voxel V, class Add>
absl::Status DecodeVoxels(const ChunkCoord& c, const OpenedChunk& opened, Add&& add) {
  const size_t n = opened.count;
  const std::string_view raw = opened.raw;
  if (raw.size() < 3 * n) return absl::DataLossError("chunk: keys truncated");
  const KeyBox box = ChunkBox(c);
  Decoder d(raw.substr(3 * n));
  // Keys are unique (as written): a repeated one would be merged with the first, into a
  // voxel the chunk does not hold (and maybe not a valid one: weights summing to infinity).
  std::bitset<size_t{1} << (3 * kChunkShift)> seen;
  for (size_t i = 0; i < n; ++i) {
    const auto lx = static_cast<uint8_t>(raw[i]), ly = static_cast<uint8_t>(raw[n + i]),
               lz = static_cast<uint8_t>(raw[2 * n + i]);
    if (lx >> kChunkShift || ly >> kChunkShift || lz >> kChunkShift) {
      return absl::DataLossError(absl::StrCat("chunk: voxel ", i, " key outside its chunk"));
    }
    const size_t local = (size_t{lx} << (2 * kChunkShift)) | (size_t{ly} << kChunkShift) | lz;
    if (seen.test(local)) {
      return absl::DataLossError(absl::StrCat("chunk: voxel ", i, " repeats a key"));
    }
    seen.set(local);
    V v;
    if (!V::Decode(d, &v))
      return absl::DataLossError(absl::StrCat("chunk: voxel ", i, " truncated"));
    if (v.IsEmpty()) return absl::DataLossError(absl::StrCat("chunk: voxel ", i, " is empty"));
    if (!add(VoxelKey{box.min.x + lx, box.min.y + ly, box.min.z + lz}, v)) {
      return absl::DataLossError(absl::StrCat("chunk: voxel ", i, " is not one of its type"));
    }
  }
  if (d.remaining() != 0) return absl::DataLossError("chunk: trailing bytes");
  return absl::OkStatus();
}

}  // namespace internal

// Decodes a blob written by EncodeVoxelChunk for chunk `c` and adds its voxels to `out`.
// A voxel type that replaced an older one (V::Legacy, V::FromLegacy) also reads chunks of
// the older type, converted (their keys stay in the chunk: blocks never straddle chunks).
// DataLoss / FailedPrecondition / InvalidArgument as OpenChunk, or for malformed voxels.
template <Voxel V>
absl::Status DecodeVoxelChunk(const ChunkCoord& c, std::string_view blob, VoxelBatch<V>* out) {
  absl::StatusOr<OpenedChunk> opened = OpenChunk(blob, ChunkContent::kVoxels, kAnyChunkType);
  if (!opened.ok()) return opened.status();
  if constexpr (requires { typename V::Legacy; }) {
    using Legacy = typename V::Legacy;
    if (opened->type == Legacy::kTypeId) {
      return internal::DecodeVoxels<Legacy>(c, *opened, [&](const VoxelKey& k, const Legacy& v) {
        VoxelKey key;
        V converted;
        if (!V::FromLegacy(k, v, &key, &converted)) return false;
        out->AddKey(key, converted);
        return true;
      });
    }
  }
  if (opened->type != V::kTypeId) {
    return absl::DataLossError(
        absl::StrCat("chunk: holds voxel type ", opened->type, ", expected type ", V::kTypeId));
  }
  return internal::DecodeVoxels<V>(c, *opened, [&](const VoxelKey& k, const V& v) {
    out->AddKey(k, v);
    return true;
  });
}

}  // namespace skimap::server

#endif  // SERVER_CORE_TRANSFER_CHUNK_CODEC_H_
