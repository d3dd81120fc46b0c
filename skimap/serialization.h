// Binary map files: versioned, little-endian, CRC-32C checked (docs/formats.md, "SkiMap
// volume file").
//
//   std::string bytes = SerializeMap(map);
//   absl::StatusOr<std::unique_ptr<SkiMap<V>>> copy = DeserializeMap<V>(bytes, options);
//
// Deserialization validates everything before trusting it: magic, format version, voxel
// type, checksum, sizes, key ranges and key order. Corrupted input yields DataLoss (bad
// checksum / truncation) or InvalidArgument (well-formed but wrong file), never a crash.
//
// Thread safety: SerializeMap is a reader (safe during writes; each column is captured in
// a consistent state, see skimap.h).
#ifndef SKIMAP_SERIALIZATION_H_
#define SKIMAP_SERIALIZATION_H_

#include <memory>
#include <string>
#include <string_view>

#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "base/encoding.h"
#include "skimap/skimap.h"

namespace skimap {

inline constexpr char kMapMagic[4] = {'S', 'K', 'M', 'P'};
inline constexpr uint32_t kMapFormatVersion = 1;
// magic, version, voxel type, resolution, origin, count.
inline constexpr size_t kMapHeaderBytes = 4 + 4 + 4 + 8 + 3 * 8 + 8;

template <Voxel V>
std::string SerializeMap(const SkiMap<V>& map) {
  std::string out;
  Encoder e(&out);
  e.Bytes(std::string_view(kMapMagic, 4));
  e.U32(kMapFormatVersion);
  e.U32(V::kTypeId);
  e.F64(map.grid().resolution());
  e.F64(map.grid().origin().x);
  e.F64(map.grid().origin().y);
  e.F64(map.grid().origin().z);
  const size_t count_at = out.size();
  e.U64(0);  // voxel count, patched below (the map may change while we write)
  uint64_t count = 0;
  map.ForEach([&](const VoxelKey& k, const V& v) {
    e.I32(k.x);
    e.I32(k.y);
    e.I32(k.z);
    v.Encode(e);
    ++count;
  });
  for (int i = 0; i < 8; ++i) out[count_at + i] = static_cast<char>(count >> (8 * i));
  e.U32(Crc32c(out));
  return out;
}

// Reads a map written by SerializeMap. `options` supplies everything but the resolution
// and origin, which come from the file.
template <Voxel V>
absl::StatusOr<std::unique_ptr<SkiMap<V>>> DeserializeMap(std::string_view bytes,
                                                          typename SkiMap<V>::Options options) {
  if (bytes.size() >= 4 && bytes.substr(0, 4) != std::string_view(kMapMagic, 4)) {
    return absl::InvalidArgumentError("map file: bad magic (not a SkiMap volume file)");
  }
  if (bytes.size() < kMapHeaderBytes + 4) {
    return absl::DataLossError(absl::StrCat("map file: truncated (", bytes.size(), " bytes)"));
  }
  const std::string_view body = bytes.substr(0, bytes.size() - 4);
  Decoder crc_in(bytes.substr(bytes.size() - 4));
  uint32_t stored_crc = 0;
  (void)crc_in.U32(&stored_crc);
  if (Crc32c(body) != stored_crc) return absl::DataLossError("map file: checksum mismatch");

  Decoder d(body.substr(4));
  uint32_t version = 0, type = 0;
  uint64_t count = 0;
  Point3 origin;
  double resolution = 0;
  (void)(d.U32(&version) && d.U32(&type) && d.F64(&resolution) && d.F64(&origin.x) &&
         d.F64(&origin.y) && d.F64(&origin.z) && d.U64(&count));
  if (version != kMapFormatVersion) {
    return absl::InvalidArgumentError(absl::StrCat("map file: unsupported version ", version));
  }
  if (type != V::kTypeId) {
    return absl::InvalidArgumentError(
        absl::StrCat("map file: voxel type ", type, ", expected ", V::kTypeId));
  }
  if (!(resolution > 0) || !std::isfinite(resolution) || !std::isfinite(origin.x) ||
      !std::isfinite(origin.y) || !std::isfinite(origin.z)) {
    return absl::InvalidArgumentError("map file: invalid resolution or origin");
  }
  if (count > d.remaining() / 12) return absl::DataLossError("map file: voxel count too large");
  options.resolution = resolution;
  options.origin = origin;
  auto map = std::make_unique<SkiMap<V>>(options);
  VoxelBatch<V> batch;
  batch.Reserve(count);
  for (uint64_t i = 0; i < count; ++i) {
    VoxelKey k;
    V v;
    if (!d.I32(&k.x) || !d.I32(&k.y) || !d.I32(&k.z) || !V::Decode(d, &v)) {
      return absl::DataLossError(absl::StrCat("map file: voxel ", i, " truncated or malformed"));
    }
    const KeyBox all;
    if (!all.Contains(k)) {
      return absl::InvalidArgumentError(absl::StrCat("map file: voxel ", i, " key out of range"));
    }
    if (!batch.empty() && !(batch.items().back().key < k)) {
      return absl::InvalidArgumentError(absl::StrCat("map file: voxel ", i, " out of order"));
    }
    if (v.IsEmpty()) {
      return absl::InvalidArgumentError(absl::StrCat("map file: voxel ", i, " is empty"));
    }
    batch.AddKey(k, v);
  }
  if (d.remaining() != 0) return absl::DataLossError("map file: trailing bytes");
  batch.Finalize();  // already sorted and unique; the radix sort keeps that order
  map->Integrate(batch);
  return map;
}

}  // namespace skimap

#endif  // SKIMAP_SERIALIZATION_H_
