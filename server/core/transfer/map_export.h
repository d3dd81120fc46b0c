// Export files: one map as one portable file (docs/formats.md, "Export file"): its options,
// every snapshot chunk the store holds (every volume and the frame index, the blobs as
// chunk_codec.h sealed them) and optionally its journal records, each record checksummed,
// then an end record with the counts and a CRC-32C of the whole file.
//
//   std::string file;
//   ExportWriter writer({.map_id = "kitchen", .options = bytes, .snapshot_position = 9,
//                        .journal_base = 9}, &file);
//   writer.AddChunk(chunk, &file);
//   writer.Finish(&file);
//
//   ExportReader reader;
//   reader.Feed(piece);                       // any split of the bytes, in order
//   while (auto record = reader.Next(); record.ok() && record->has_value()) { ... }
//   absl::Status whole = reader.Finish();     // DataLoss if the file ended early
//
// Order (REQUIRED of writers, checked by the reader): header, the map record, chunks,
// journal records at consecutive positions from journal_base + 1, the end record, nothing
// after it. The writer does not check it.
//
// Versions: the reader knows every version up to kExportFormatVersion (only 1 so far) and
// dispatches on the version in the header; a newer file is FailedPrecondition
// ("export file format version 2 is newer than this server's 1; upgrade skimapd").
// Corruption and truncation are DataLoss naming the record (its index, counting the header
// as 0, and type) and its byte offset. No input crashes the reader; it holds the bytes fed
// and not yet parsed (a record is parsed once it is whole; records above
// kMaxExportRecordBytes are refused from their header).
//
// Thread safety: ExportWriter and ExportReader are single-threaded values.
#ifndef SERVER_CORE_TRANSFER_MAP_EXPORT_H_
#define SERVER_CORE_TRANSFER_MAP_EXPORT_H_

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <variant>

#include "absl/status/statusor.h"
#include "storage/map_store.h"

namespace skimap::server {

inline constexpr uint32_t kExportFormatVersion = 1;
// Largest record payload accepted: a journal record holds one frame (images up to the
// server's message limit) or one pose update.
inline constexpr uint32_t kMaxExportRecordBytes = 1u << 30;

// The header and the map record: what the file is of.
struct ExportedMap {
  std::string map_id;              // the id it was exported from
  std::string options;             // v1::MapOptions, serialized
  uint64_t snapshot_position = 0;  // the journal position the chunks cover
  // The journal in the file starts at journal_base + 1; positions up to journal_base are
  // not in it (pruned, or the file has no journal: then journal_base = snapshot_position).
  uint64_t journal_base = 0;
};

// The end record.
struct ExportEnd {
  uint64_t chunks = 0;
  uint64_t journal_records = 0;
};

using ExportRecord = std::variant<ExportedMap, storage::Chunk, storage::JournalRecord, ExportEnd>;

// Appends an export file to strings, piece by piece (each call appends to *out, which
// may be a new string every time). Keeps the running counts and whole-file checksum.
class ExportWriter {
 public:
  // Appends the header and the map record.
  ExportWriter(const ExportedMap& map, std::string* out);
  void AddChunk(const storage::Chunk& chunk, std::string* out);
  void AddJournal(const storage::JournalRecord& record, std::string* out);
  // Appends the end record. Nothing may be added after it.
  void Finish(std::string* out);

 private:
  // Appends the CRC-32C of the record written from out[record_start] on and adds the
  // record to the whole-file checksum.
  void Seal(std::string* out, size_t record_start);

  uint32_t file_crc_ = 0;  // CRC-32C of every byte written so far
  ExportEnd counts_;
};

// Parses an export file fed in pieces (in order, split anywhere).
class ExportReader {
 public:
  // Appends the next bytes of the file.
  void Feed(std::string_view bytes);
  // The next complete record, or nullopt when more bytes are needed (or after the end
  // record). After an error, every call returns that error.
  absl::StatusOr<std::optional<ExportRecord>> Next();
  // Call after the last bytes: OK once the end record was read and nothing follows it;
  // DataLoss naming where the file stops otherwise. Records not taken with Next yet are
  // parsed (and checked) but dropped.
  absl::Status Finish();

  uint32_t version() const { return version_; }  // 0 until the header was read
  uint64_t offset() const { return consumed_; }  // bytes of the file parsed so far

 private:
  absl::StatusOr<std::optional<ExportRecord>> NextV1();
  absl::Status ReadHeader();
  absl::Status Fail(absl::Status s);
  // Stores `s` as the reader's error, naming the current record.
  absl::Status RecordError(uint8_t type, const std::string& what);
  // Checks a parsed record against the order and counts of the file so far.
  absl::Status CheckOrder(const ExportRecord& record, uint8_t type);

  std::string buffer_;
  size_t start_ = 0;           // first unparsed byte of buffer_
  uint64_t consumed_ = 0;      // file offset of buffer_[start_]
  uint32_t file_crc_ = 0;      // CRC-32C of the bytes parsed so far
  uint32_t version_ = 0;       // from the header
  std::string header_id_;      // map id from the header
  uint64_t records_ = 0;       // records parsed (the header counts as record 0)
  bool have_map_ = false;      // the map record was read
  bool ended_ = false;         // the end record was read
  uint64_t journal_base_ = 0;  // from the map record
  uint64_t snapshot_position_ = 0;
  uint64_t last_position_ = 0;  // of the last journal record (journal_base_ before one)
  ExportEnd counts_;
  absl::Status error_;
};

}  // namespace skimap::server

#endif  // SERVER_CORE_TRANSFER_MAP_EXPORT_H_
