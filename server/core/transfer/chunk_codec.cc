#include "server/core/transfer/chunk_codec.h"

#include "codec/zstd_frame.h"

namespace skimap::server {
namespace {

constexpr char kChunkMagic[4] = {'S', 'K', 'C', 'K'};
constexpr size_t kHeaderBytes = 4 + 2 + 1 + 1 + 4 + 4 + 4;
constexpr uint8_t kCodecRaw = 0, kCodecZstd = 1;
// Fast: snapshots run beside ingestion; level 1 is within a few percent of level 3 here.
constexpr int kZstdLevel = 1;
// A chunk is at most 32^3 voxels of a few dozen bytes; larger claims are corrupt.
constexpr uint32_t kMaxRawBytes = 256u << 20;

}  // namespace

std::string SealChunk(ChunkContent content, uint32_t type, uint32_t count, std::string raw) {
  const absl::StatusOr<std::string> packed = perception::ZstdCompress(raw, kZstdLevel);
  const bool zstd = packed.ok() && packed->size() < raw.size();
  std::string out;
  out.reserve(kHeaderBytes + (zstd ? packed->size() : raw.size()) + 4);
  Encoder e(&out);
  e.Bytes(std::string_view(kChunkMagic, 4));
  e.U8(kChunkFormatVersion & 0xff);
  e.U8(kChunkFormatVersion >> 8);
  e.U8(zstd ? kCodecZstd : kCodecRaw);
  e.U8(static_cast<uint8_t>(content));
  e.U32(type);
  e.U32(count);
  e.U32(static_cast<uint32_t>(raw.size()));
  e.Bytes(zstd ? std::string_view(*packed) : std::string_view(raw));
  e.U32(Crc32c(out));
  return out;
}

absl::StatusOr<OpenedChunk> OpenChunk(std::string_view blob, ChunkContent content, uint32_t type) {
  if (blob.size() < kHeaderBytes + 4) {
    return absl::DataLossError(absl::StrCat("chunk: truncated (", blob.size(), " bytes)"));
  }
  if (blob.substr(0, 4) != std::string_view(kChunkMagic, 4)) {
    return absl::DataLossError("chunk: bad magic (not a SkiMap chunk)");
  }
  Decoder d(blob.substr(4, kHeaderBytes - 4));
  uint8_t v0 = 0, v1 = 0, codec = 0, kind = 0;
  uint32_t stored_type = 0, count = 0, raw_size = 0;
  (void)(d.U8(&v0) && d.U8(&v1) && d.U8(&codec) && d.U8(&kind) && d.U32(&stored_type) &&
         d.U32(&count) && d.U32(&raw_size));
  const uint16_t version = static_cast<uint16_t>(v0 | v1 << 8);
  // The version is read before the checksum so that a newer file gets the clear message.
  if (version > kChunkFormatVersion) {
    return absl::FailedPreconditionError(absl::StrCat("chunk: format version ", version,
                                                      " is newer than this server's (",
                                                      kChunkFormatVersion, "); upgrade skimapd"));
  }
  const std::string_view body = blob.substr(0, blob.size() - 4);
  Decoder crc_in(blob.substr(blob.size() - 4));
  uint32_t crc = 0;
  (void)crc_in.U32(&crc);
  if (Crc32c(body) != crc) return absl::DataLossError("chunk: checksum mismatch");
  if (version == 0) return absl::DataLossError("chunk: format version 0");
  if (kind != static_cast<uint8_t>(content) || (type != kAnyChunkType && stored_type != type)) {
    return absl::DataLossError(absl::StrCat("chunk: holds content ", kind, " type ", stored_type,
                                            ", expected ", static_cast<int>(content), " type ",
                                            type));
  }
  if (raw_size > kMaxRawBytes) return absl::DataLossError("chunk: raw size too large");
  const std::string_view payload = body.substr(kHeaderBytes);
  OpenedChunk out;
  out.count = count;
  out.type = stored_type;
  if (codec == kCodecRaw) {
    if (payload.size() != raw_size) return absl::DataLossError("chunk: raw size mismatch");
    out.raw.assign(payload);
  } else if (codec == kCodecZstd) {
    // A zstd block yields at most 128 KiB from at least 4 bytes (an RLE block), so a payload
    // cannot expand beyond that: a larger claim is refused before anything is allocated
    // (a few corrupt bytes must not cost hundreds of megabytes).
    if (raw_size / (128u << 10) > payload.size() / 4 + 1 ||
        !perception::ZstdCheckFrame(payload, raw_size).ok()) {
      return absl::DataLossError("chunk: zstd payload does not match its raw size");
    }
    out.raw.resize(raw_size);
    if (!perception::ZstdDecompressExact(payload, out.raw.data(), raw_size).ok()) {
      return absl::DataLossError("chunk: zstd payload corrupt");
    }
  } else {
    return absl::DataLossError(absl::StrCat("chunk: unknown codec ", codec));
  }
  return out;
}

}  // namespace skimap::server
