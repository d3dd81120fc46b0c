#include "server/core/transfer/map_meta.h"

#include "base/encoding.h"
#include "server/core/transfer/chunk_codec.h"

namespace skimap::server {
namespace {

constexpr uint32_t kMetaType = 1;  // u64 next_instance_id, u64 last_event_sequence, u64 fingerprint

}  // namespace

std::string EncodeMapMeta(const MapMeta& meta) {
  std::string raw;
  Encoder e(&raw);
  e.U64(meta.next_instance_id);
  e.U64(meta.last_event_sequence);
  e.U64(meta.fingerprint);
  return SealChunk(ChunkContent::kMapMeta, kMetaType, 1, std::move(raw));
}

absl::StatusOr<MapMeta> DecodeMapMeta(std::string_view blob) {
  absl::StatusOr<OpenedChunk> opened = OpenChunk(blob, ChunkContent::kMapMeta, kMetaType);
  if (!opened.ok()) return opened.status();
  MapMeta meta;
  Decoder d(opened->raw);
  if (opened->count != 1 || !d.U64(&meta.next_instance_id) || !d.U64(&meta.last_event_sequence) ||
      !d.U64(&meta.fingerprint) || d.remaining() != 0 || meta.next_instance_id == 0) {
    return absl::DataLossError("map meta chunk: malformed");
  }
  return meta;
}

}  // namespace skimap::server
