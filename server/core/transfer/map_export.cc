#include "server/core/transfer/map_export.h"

#include <algorithm>
#include <cstdint>
#include <utility>

#include "absl/strings/str_cat.h"
#include "base/encoding.h"

namespace skimap::server {
namespace {

constexpr char kExportMagic[4] = {'S', 'K', 'E', 'X'};
constexpr size_t kMagicAndVersionBytes = 8;
constexpr size_t kMaxMapIdBytes = 255;
constexpr size_t kMaxVolumeNameBytes = 64;
// v1 records: u8 type | u32 payload length | payload | u32 CRC-32C of all before it.
constexpr size_t kRecordHeaderBytes = 5;
constexpr size_t kRecordCrcBytes = 4;
constexpr uint8_t kMapRecord = 1, kChunkRecord = 2, kJournalRecord = 3, kEndRecord = 4;
constexpr size_t kMapFixedBytes = 16;         // snapshot position, journal base
constexpr size_t kChunkFixedBytes = 1 + 24;   // name length, x, y, z
constexpr size_t kJournalFixedBytes = 1 + 8;  // kind, position
constexpr size_t kEndBytes = 8 + 8 + 4;       // counts, file CRC

std::string TypeName(uint8_t type) {
  switch (type) {
    case kMapRecord:
      return "map";
    case kChunkRecord:
      return "chunk";
    case kJournalRecord:
      return "journal";
    case kEndRecord:
      return "end";
    default:
      return absl::StrCat("type ", type);
  }
}

uint32_t ReadU32(std::string_view b) {
  uint32_t v = 0;
  Decoder d(b);
  (void)d.U32(&v);
  return v;
}

absl::Status Loss(const std::string& what) {
  return absl::DataLossError(absl::StrCat("export file: ", what));
}

}  // namespace

// ---- ExportWriter ----

ExportWriter::ExportWriter(const ExportedMap& map, std::string* out) {
  const size_t start = out->size();
  Encoder e(out);
  e.Bytes(std::string_view(kExportMagic, 4));
  e.U32(kExportFormatVersion);
  const std::string_view id = std::string_view(map.map_id).substr(0, kMaxMapIdBytes);
  e.U8(static_cast<uint8_t>(id.size() & 0xff));
  e.U8(static_cast<uint8_t>(id.size() >> 8));
  e.Bytes(id);
  e.U32(Crc32c(std::string_view(*out).substr(start)));
  file_crc_ = Crc32c(std::string_view(*out).substr(start), file_crc_);

  const size_t record = out->size();
  e.U8(kMapRecord);
  e.U32(static_cast<uint32_t>(kMapFixedBytes + map.options.size()));
  e.U64(map.snapshot_position);
  e.U64(map.journal_base);
  e.Bytes(map.options);
  Seal(out, record);
}

void ExportWriter::AddChunk(const storage::Chunk& chunk, std::string* out) {
  const size_t record = out->size();
  const std::string_view name = std::string_view(chunk.key.volume).substr(0, kMaxVolumeNameBytes);
  Encoder e(out);
  e.U8(kChunkRecord);
  e.U32(static_cast<uint32_t>(kChunkFixedBytes + name.size() + chunk.bytes.size()));
  e.U8(static_cast<uint8_t>(name.size()));
  e.Bytes(name);
  e.U64(static_cast<uint64_t>(chunk.key.x));
  e.U64(static_cast<uint64_t>(chunk.key.y));
  e.U64(static_cast<uint64_t>(chunk.key.z));
  e.Bytes(chunk.bytes);
  Seal(out, record);
  ++counts_.chunks;
}

void ExportWriter::AddJournal(const storage::JournalRecord& r, std::string* out) {
  const size_t record = out->size();
  Encoder e(out);
  e.U8(kJournalRecord);
  e.U32(static_cast<uint32_t>(kJournalFixedBytes + r.payload.size()));
  e.U8(static_cast<uint8_t>(r.kind));
  e.U64(r.position);
  e.Bytes(r.payload);
  Seal(out, record);
  ++counts_.journal_records;
}

void ExportWriter::Finish(std::string* out) {
  const size_t record = out->size();
  const uint32_t before_end = file_crc_;
  Encoder e(out);
  e.U8(kEndRecord);
  e.U32(kEndBytes);
  e.U64(counts_.chunks);
  e.U64(counts_.journal_records);
  e.U32(before_end);
  Seal(out, record);
}

void ExportWriter::Seal(std::string* out, size_t record_start) {
  Encoder(out).U32(Crc32c(std::string_view(*out).substr(record_start)));
  file_crc_ = Crc32c(std::string_view(*out).substr(record_start), file_crc_);
}

// ---- ExportReader ----

void ExportReader::Feed(std::string_view bytes) {
  if (start_ == buffer_.size()) {
    buffer_.clear();
    start_ = 0;
  } else if (start_ >= (size_t{1} << 20) && 2 * start_ >= buffer_.size()) {
    buffer_.erase(0, start_);
    start_ = 0;
  }
  buffer_.append(bytes);
}

absl::Status ExportReader::Fail(absl::Status s) {
  error_ = std::move(s);
  return error_;
}

absl::Status ExportReader::RecordError(uint8_t type, const std::string& what) {
  return Fail(Loss(absl::StrCat("record ", records_, " (", TypeName(type), ") at offset ",
                                consumed_, ": ", what)));
}

absl::Status ExportReader::ReadHeader() {
  const std::string_view in = std::string_view(buffer_).substr(start_);
  const size_t magic = std::min<size_t>(in.size(), 4);
  if (in.substr(0, magic) != std::string_view(kExportMagic, magic)) {
    return Fail(Loss("not a SkiMap export file (bad magic)"));
  }
  if (in.size() < kMagicAndVersionBytes) return absl::OkStatus();  // more bytes needed
  // The version is read before any checksum: a newer file gets the clear message.
  const uint32_t version = ReadU32(in.substr(4, 4));
  if (version > kExportFormatVersion) {
    return Fail(absl::FailedPreconditionError(
        absl::StrCat("export file format version ", version, " is newer than this server's ",
                     kExportFormatVersion, "; upgrade skimapd")));
  }
  switch (version) {
    case 1: {
      // v1 header: magic | u32 version | u16 id length | id | u32 CRC-32C of all before it.
      if (in.size() < kMagicAndVersionBytes + 2) return absl::OkStatus();
      const size_t id_bytes = uint8_t(in[8]) | size_t{uint8_t(in[9])} << 8;
      if (id_bytes == 0 || id_bytes > kMaxMapIdBytes) {
        return Fail(
            Loss(absl::StrCat("header: map id of ", id_bytes, " bytes (1..", kMaxMapIdBytes, ")")));
      }
      const size_t header_bytes = kMagicAndVersionBytes + 2 + id_bytes + 4;
      if (in.size() < header_bytes) return absl::OkStatus();
      const std::string_view body = in.substr(0, header_bytes - 4);
      if (Crc32c(body) != ReadU32(in.substr(header_bytes - 4, 4))) {
        return Fail(Loss("header: checksum mismatch"));
      }
      header_id_.assign(in.substr(kMagicAndVersionBytes + 2, id_bytes));
      file_crc_ = Crc32c(in.substr(0, header_bytes));
      start_ += header_bytes;
      consumed_ += header_bytes;
      records_ = 1;
      version_ = version;
      return absl::OkStatus();
    }
    default:
      return Fail(Loss(absl::StrCat("format version ", version, " does not exist")));
  }
}

absl::StatusOr<std::optional<ExportRecord>> ExportReader::Next() {
  if (!error_.ok()) return error_;
  if (version_ == 0) {
    if (absl::Status s = ReadHeader(); !s.ok()) return s;
    if (version_ == 0) return std::nullopt;
  }
  if (ended_) {
    if (start_ < buffer_.size()) {
      return Fail(Loss(absl::StrCat(buffer_.size() - start_,
                                    " bytes after the end record at offset ", consumed_)));
    }
    return std::nullopt;
  }
  switch (version_) {
    case 1:
      return NextV1();
    default:  // ReadHeader accepts only the versions above
      return Fail(absl::InternalError("export file: unhandled format version"));
  }
}

absl::StatusOr<std::optional<ExportRecord>> ExportReader::NextV1() {
  const std::string_view in = std::string_view(buffer_).substr(start_);
  if (in.size() < kRecordHeaderBytes) return std::nullopt;
  const uint8_t type = static_cast<uint8_t>(in[0]);
  const uint32_t length = ReadU32(in.substr(1, 4));
  if (length > kMaxExportRecordBytes) {
    return RecordError(type, absl::StrCat("length ", length, " exceeds the limit of ",
                                          kMaxExportRecordBytes, " bytes"));
  }
  const size_t record_bytes = kRecordHeaderBytes + size_t{length} + kRecordCrcBytes;
  if (in.size() < record_bytes) return std::nullopt;
  const std::string_view record = in.substr(0, record_bytes);
  if (Crc32c(record.substr(0, record_bytes - kRecordCrcBytes)) !=
      ReadU32(record.substr(record_bytes - kRecordCrcBytes))) {
    return RecordError(type, "checksum mismatch");
  }
  const std::string_view payload = record.substr(kRecordHeaderBytes, length);
  Decoder d(payload);
  ExportRecord out;
  switch (type) {
    case kMapRecord: {
      ExportedMap map;
      map.map_id = header_id_;
      if (!d.U64(&map.snapshot_position) || !d.U64(&map.journal_base)) {
        return RecordError(type, "shorter than its fixed fields");
      }
      map.options.assign(payload.substr(kMapFixedBytes));
      out = std::move(map);
      break;
    }
    case kChunkRecord: {
      storage::Chunk chunk;
      uint8_t name_bytes = 0;
      if (!d.U8(&name_bytes) || name_bytes == 0 || name_bytes > kMaxVolumeNameBytes ||
          d.remaining() < name_bytes + 24u) {
        return RecordError(type, "bad volume name length or fields truncated");
      }
      chunk.key.volume.assign(payload.substr(1, name_bytes));
      Decoder coords(payload.substr(1 + name_bytes, 24));
      uint64_t x = 0, y = 0, z = 0;
      (void)(coords.U64(&x) && coords.U64(&y) && coords.U64(&z));
      chunk.key.x = static_cast<int64_t>(x);
      chunk.key.y = static_cast<int64_t>(y);
      chunk.key.z = static_cast<int64_t>(z);
      chunk.bytes.assign(payload.substr(kChunkFixedBytes + name_bytes));
      out = std::move(chunk);
      break;
    }
    case kJournalRecord: {
      storage::JournalRecord r;
      uint8_t kind = 0;
      if (!d.U8(&kind) || !d.U64(&r.position)) {
        return RecordError(type, "shorter than its fixed fields");
      }
      if (kind != storage::JournalRecord::kFrame && kind != storage::JournalRecord::kPoseUpdate) {
        return RecordError(type, absl::StrCat("unknown journal record kind ", kind));
      }
      r.kind = static_cast<storage::JournalRecord::Kind>(kind);
      r.payload.assign(payload.substr(kJournalFixedBytes));
      out = std::move(r);
      break;
    }
    case kEndRecord: {
      ExportEnd end;
      uint32_t crc = 0;
      if (length != kEndBytes || !d.U64(&end.chunks) || !d.U64(&end.journal_records) ||
          !d.U32(&crc)) {
        return RecordError(type, absl::StrCat("payload of ", length, " bytes, not ", kEndBytes));
      }
      if (crc != file_crc_) return RecordError(type, "whole-file checksum mismatch");
      out = end;
      break;
    }
    default:
      return RecordError(type, "unknown record type");
  }
  if (absl::Status s = CheckOrder(out, type); !s.ok()) return s;
  file_crc_ = Crc32c(record, file_crc_);
  start_ += record_bytes;
  consumed_ += record_bytes;
  ++records_;
  return out;
}

absl::Status ExportReader::CheckOrder(const ExportRecord& record, uint8_t type) {
  if (!have_map_ && type != kMapRecord) return RecordError(type, "the map record must come first");
  if (const auto* map = std::get_if<ExportedMap>(&record)) {
    if (have_map_) return RecordError(type, "a second map record");
    if (map->snapshot_position > uint64_t{INT64_MAX}) {
      return RecordError(type, "snapshot position beyond 2^63");
    }
    if (map->journal_base > map->snapshot_position) {
      return RecordError(type,
                         absl::StrCat("journal base ", map->journal_base,
                                      " is beyond the snapshot position ", map->snapshot_position));
    }
    have_map_ = true;
    journal_base_ = last_position_ = map->journal_base;
    snapshot_position_ = map->snapshot_position;
  } else if (std::holds_alternative<storage::Chunk>(record)) {
    if (counts_.journal_records > 0) return RecordError(type, "a chunk after journal records");
    ++counts_.chunks;
  } else if (const auto* r = std::get_if<storage::JournalRecord>(&record)) {
    if (r->position != last_position_ + 1) {
      return RecordError(type, absl::StrCat("journal position ", r->position, " where ",
                                            last_position_ + 1, " was expected"));
    }
    last_position_ = r->position;
    ++counts_.journal_records;
  } else if (const auto* end = std::get_if<ExportEnd>(&record)) {
    if (end->chunks != counts_.chunks || end->journal_records != counts_.journal_records) {
      return RecordError(type, absl::StrCat("counts ", end->chunks, " chunks and ",
                                            end->journal_records, " journal records, the file has ",
                                            counts_.chunks, " and ", counts_.journal_records));
    }
    if (last_position_ < snapshot_position_) {
      return RecordError(type, absl::StrCat("the journal ends at position ", last_position_,
                                            ", before the snapshot position ", snapshot_position_));
    }
    ended_ = true;
  }
  return absl::OkStatus();
}

absl::Status ExportReader::Finish() {
  if (!error_.ok()) return error_;
  // Parse whatever complete records are still buffered.
  for (;;) {
    absl::StatusOr<std::optional<ExportRecord>> r = Next();
    if (!r.ok()) return r.status();
    if (!r->has_value()) break;
  }
  if (ended_) return absl::OkStatus();
  const size_t left = buffer_.size() - start_;
  if (version_ == 0) {
    return Fail(Loss(consumed_ + left == 0
                         ? std::string("empty")
                         : absl::StrCat("truncated in the header (", left, " bytes)")));
  }
  if (left == 0) {
    return Fail(Loss(absl::StrCat("truncated: ends at offset ", consumed_, " after record ",
                                  records_ - 1, ", without an end record")));
  }
  const std::string_view in = std::string_view(buffer_).substr(start_);
  if (left < kRecordHeaderBytes) {
    return RecordError(uint8_t(in[0]), absl::StrCat("truncated: ", left, " bytes of its header"));
  }
  const size_t need = kRecordHeaderBytes + size_t{ReadU32(in.substr(1, 4))} + kRecordCrcBytes;
  return RecordError(uint8_t(in[0]), absl::StrCat("truncated: ", left, " of its ", need, " bytes"));
}

}  // namespace skimap::server
