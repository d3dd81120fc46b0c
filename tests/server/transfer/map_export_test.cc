// The export file format (server/core/transfer/map_export.h): every record type round trips, any
// split of the bytes reads the same, and corruption or truncation anywhere is an error
// naming where, never a crash.
#include "server/core/transfer/map_export.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "base/encoding.h"

namespace skimap::server {
namespace {

using ::testing::HasSubstr;

const ExportedMap kMap{.map_id = "kitchen",
                       .options = std::string("\x09\x9a\x99\x99\x99\x99\x99\xa9\x3f", 9),
                       .snapshot_position = 12,
                       .journal_base = 10};

storage::Chunk MakeChunk(std::string volume, int64_t x, int64_t y, int64_t z, std::string bytes) {
  storage::Chunk c;
  c.key.volume = std::move(volume);
  c.key.x = x;
  c.key.y = y;
  c.key.z = z;
  c.bytes = std::move(bytes);
  return c;
}

// A file with every record type: 3 chunks (one of the frame index), journal 11..13.
std::string SampleFile() {
  std::string file;
  ExportWriter w(kMap, &file);
  w.AddChunk(MakeChunk("free", -1, 0, 0, "FREE"), &file);
  w.AddChunk(MakeChunk("frames", 0, 0, 0, std::string("\0index\xff", 7)), &file);
  w.AddChunk(MakeChunk("rgb", -3, 2, -2147483648LL, std::string(3000, 'v')), &file);
  w.AddJournal({storage::JournalRecord::kFrame, std::string(5000, 'f'), 11}, &file);
  w.AddJournal({storage::JournalRecord::kPoseUpdate, "pose", 12}, &file);
  w.AddJournal({storage::JournalRecord::kFrame, "", 13}, &file);
  w.Finish(&file);
  return file;
}

// Everything a reader makes of `pieces`: the records, then the status that ended it.
struct Parsed {
  std::vector<ExportRecord> records;
  absl::Status status;
};
Parsed Parse(const std::vector<std::string_view>& pieces) {
  Parsed out;
  ExportReader reader;
  for (std::string_view piece : pieces) {
    reader.Feed(piece);
    for (;;) {
      absl::StatusOr<std::optional<ExportRecord>> r = reader.Next();
      if (!r.ok()) {
        out.status = r.status();
        return out;
      }
      if (!r->has_value()) break;
      out.records.push_back(**r);
    }
  }
  out.status = reader.Finish();
  return out;
}
Parsed Parse(std::string_view file) { return Parse(std::vector<std::string_view>{file}); }

// One v1 record with its checksum, for files the writer would not write.
std::string Record(uint8_t type, std::string_view payload) {
  std::string out;
  Encoder e(&out);
  e.U8(type);
  e.U32(static_cast<uint32_t>(payload.size()));
  e.Bytes(payload);
  e.U32(Crc32c(out));
  return out;
}
std::string EndRecord(const std::string& before, uint64_t chunks, uint64_t journal) {
  std::string payload;
  Encoder e(&payload);
  e.U64(chunks);
  e.U64(journal);
  e.U32(Crc32c(before));
  return Record(4, payload);
}

TEST(MapExportTest, EveryRecordTypeRoundTrips) {
  const Parsed parsed = Parse(SampleFile());
  ASSERT_TRUE(parsed.status.ok()) << parsed.status;
  ASSERT_EQ(parsed.records.size(), 8u);
  const auto& map = std::get<ExportedMap>(parsed.records[0]);
  EXPECT_EQ(map.map_id, "kitchen");
  EXPECT_EQ(map.options, kMap.options);
  EXPECT_EQ(map.snapshot_position, 12u);
  EXPECT_EQ(map.journal_base, 10u);
  const auto& chunk = std::get<storage::Chunk>(parsed.records[3]);
  EXPECT_EQ(chunk.key, (storage::ChunkKey{"rgb", -3, 2, -2147483648LL}));
  EXPECT_EQ(chunk.bytes, std::string(3000, 'v'));
  EXPECT_EQ(std::get<storage::Chunk>(parsed.records[2]).bytes, std::string("\0index\xff", 7));
  const auto& frame = std::get<storage::JournalRecord>(parsed.records[4]);
  EXPECT_EQ(frame.kind, storage::JournalRecord::kFrame);
  EXPECT_EQ(frame.position, 11u);
  EXPECT_EQ(frame.payload.size(), 5000u);
  const auto& pose = std::get<storage::JournalRecord>(parsed.records[5]);
  EXPECT_EQ(pose.kind, storage::JournalRecord::kPoseUpdate);
  EXPECT_EQ(pose.payload, "pose");
  const auto& end = std::get<ExportEnd>(parsed.records[7]);
  EXPECT_EQ(end.chunks, 3u);
  EXPECT_EQ(end.journal_records, 3u);
}

TEST(MapExportTest, AFileWithoutChunksOrJournalIsValid) {
  std::string file;
  ExportWriter w({.map_id = "empty", .options = "", .snapshot_position = 0, .journal_base = 0},
                 &file);
  w.Finish(&file);
  const Parsed parsed = Parse(file);
  ASSERT_TRUE(parsed.status.ok()) << parsed.status;
  EXPECT_EQ(parsed.records.size(), 2u);
}

TEST(MapExportTest, AnySplitOfTheBytesReadsTheSame) {
  const std::string file = SampleFile();
  const size_t whole = Parse(file).records.size();
  std::mt19937 rng(7);
  for (int trial = 0; trial < 50; ++trial) {
    std::vector<std::string_view> pieces;
    for (size_t at = 0; at < file.size();) {
      const size_t n = trial == 0 ? 1 : std::uniform_int_distribution<size_t>(0, 900)(rng);
      pieces.push_back(std::string_view(file).substr(at, n));
      at += n;
    }
    const Parsed parsed = Parse(pieces);
    ASSERT_TRUE(parsed.status.ok()) << parsed.status;
    EXPECT_EQ(parsed.records.size(), whole);
  }
}

TEST(MapExportTest, EveryFlippedByteIsAnErrorNamingWhere) {
  const std::string file = SampleFile();
  for (size_t i = 0; i < file.size(); ++i) {
    for (uint8_t mask : {0x01, 0x80, 0xff}) {
      std::string bad = file;
      bad[i] = static_cast<char>(bad[i] ^ mask);
      const absl::Status s = Parse(bad).status;
      ASSERT_FALSE(s.ok()) << "byte " << i;
      if (i >= 4 && i < 8) {  // the version field: newer, or a version that never existed
        EXPECT_THAT(s.code(), ::testing::AnyOf(absl::StatusCode::kFailedPrecondition,
                                               absl::StatusCode::kDataLoss));
      } else {
        EXPECT_EQ(s.code(), absl::StatusCode::kDataLoss) << "byte " << i << ": " << s;
      }
      EXPECT_THAT(s.message(), HasSubstr("export file"));
    }
  }
}

TEST(MapExportTest, RandomDamageNeverCrashes) {
  const std::string file = SampleFile();
  std::mt19937 rng(11);
  for (int trial = 0; trial < 3000; ++trial) {
    std::string bad = file;
    const int flips = std::uniform_int_distribution<int>(1, 8)(rng);
    for (int f = 0; f < flips; ++f) {
      bad[std::uniform_int_distribution<size_t>(0, bad.size() - 1)(rng)] = static_cast<char>(rng());
    }
    bad.resize(std::uniform_int_distribution<size_t>(0, bad.size())(rng));
    EXPECT_FALSE(Parse(bad).status.ok());
  }
}

TEST(MapExportTest, EveryTruncationIsDataLossNamingWhere) {
  const std::string file = SampleFile();
  for (size_t n = 0; n < file.size(); ++n) {
    const Parsed parsed = Parse(std::string_view(file).substr(0, n));
    ASSERT_EQ(parsed.status.code(), absl::StatusCode::kDataLoss) << n;
    EXPECT_THAT(parsed.status.message(), HasSubstr("export file"));
  }
  // Inside the first chunk record (record 2: the header is record 0, the map record 1).
  std::string one_chunk;
  ExportWriter w(kMap, &one_chunk);
  const size_t chunk_at = one_chunk.size();
  w.AddChunk(MakeChunk("rgb", 0, 0, 0, "0123456789"), &one_chunk);
  const Parsed cut = Parse(std::string_view(one_chunk).substr(0, one_chunk.size() - 3));
  EXPECT_EQ(cut.status.message(), absl::StrCat("export file: record 2 (chunk) at offset ", chunk_at,
                                               ": truncated: ", one_chunk.size() - 3 - chunk_at,
                                               " of its ", one_chunk.size() - chunk_at, " bytes"));
  // Whole records but no end record.
  EXPECT_THAT(Parse(one_chunk).status.message(), HasSubstr("without an end record"));
}

TEST(MapExportTest, ANewerVersionIsRefusedWithAClearMessage) {
  std::string file = SampleFile();
  file[4] = 2;  // version 2, little-endian
  const absl::Status s = Parse(file).status;
  EXPECT_EQ(s.code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_EQ(s.message(),
            "export file format version 2 is newer than this server's 1; upgrade skimapd");
  // Only the first 8 bytes are needed to tell.
  EXPECT_EQ(Parse(std::string_view(file).substr(0, 8)).status, s);
}

TEST(MapExportTest, NotAnExportFileIsDataLoss) {
  EXPECT_THAT(Parse("PK\x03\x04 a zip file").status.message(), HasSubstr("bad magic"));
  EXPECT_THAT(Parse("").status.message(), HasSubstr("empty"));
  std::string file = SampleFile();
  file[4] = 0;  // version 0 never existed
  EXPECT_EQ(Parse(file).status.code(), absl::StatusCode::kDataLoss);
}

TEST(MapExportTest, TheOrderOfRecordsIsChecked) {
  auto error_of = [](const std::function<void(ExportWriter&, std::string*)>& body,
                     const ExportedMap& map = kMap) {
    std::string file;
    ExportWriter w(map, &file);
    body(w, &file);
    w.Finish(&file);
    return Parse(file).status;
  };
  using storage::JournalRecord;
  EXPECT_THAT(error_of([](ExportWriter& w, std::string* f) {
                w.AddJournal({JournalRecord::kFrame, "a", 11}, f);
                w.AddJournal({JournalRecord::kFrame, "b", 13}, f);
              }).message(),
              HasSubstr("record 3 (journal) at offset"));
  EXPECT_THAT(error_of([](ExportWriter& w, std::string* f) {
                w.AddJournal({JournalRecord::kFrame, "a", 12}, f);  // 11 expected
              }).message(),
              HasSubstr("journal position 12 where 11 was expected"));
  EXPECT_THAT(error_of([](ExportWriter& w, std::string* f) {
                w.AddJournal({JournalRecord::kFrame, "a", 11}, f);
                w.AddJournal({JournalRecord::kFrame, "b", 12}, f);
                w.AddChunk(MakeChunk("rgb", 0, 0, 0, "c"), f);
              }).message(),
              HasSubstr("a chunk after journal records"));
  // The journal must reach the snapshot (12) from the base (10).
  EXPECT_THAT(error_of([](ExportWriter& w, std::string* f) {
                w.AddJournal({JournalRecord::kFrame, "a", 11}, f);
              }).message(),
              HasSubstr("the journal ends at position 11, before the snapshot position 12"));
  ExportedMap odd = kMap;
  odd.journal_base = 13;
  EXPECT_THAT(error_of([](ExportWriter&, std::string*) {}, odd).message(),
              HasSubstr("journal base 13 is beyond the snapshot position 12"));
  // Bytes after the end record.
  std::string file = SampleFile() + "x";
  EXPECT_THAT(Parse(file).status.message(), HasSubstr("1 bytes after the end record"));
}

TEST(MapExportTest, HandMadeRecordsAreChecked) {
  std::string header;
  ExportWriter w({.map_id = "m", .snapshot_position = 0, .journal_base = 0}, &header);
  // An unknown record type with a valid checksum.
  std::string file = header + Record(9, "zz");
  EXPECT_THAT(Parse(file).status.message(), HasSubstr("(type 9) at offset"));
  // An end record whose counts disagree with the file.
  file = header + Record(2, std::string("\x03rgb", 4) + std::string(24, '\0') + "blob");
  EXPECT_THAT(Parse(file + EndRecord(file, 2, 0)).status.message(),
              HasSubstr("counts 2 chunks and 0 journal records, the file has 1 and 0"));
  EXPECT_TRUE(Parse(file + EndRecord(file, 1, 0)).status.ok());
  // A chunk record whose volume name runs past its payload.
  file = header + Record(2, "\x40rgb");
  EXPECT_THAT(Parse(file + EndRecord(file, 1, 0)).status.message(),
              HasSubstr("bad volume name length"));
  // A journal record of an unknown kind.
  file = header + Record(3, std::string("\x07\x01\0\0\0\0\0\0\0", 9));
  EXPECT_THAT(Parse(file + EndRecord(file, 0, 1)).status.message(),
              HasSubstr("unknown journal record kind 7"));
  // A record claiming more than the limit is refused from its header.
  std::string huge = header;
  Encoder e(&huge);
  e.U8(3);
  e.U32(kMaxExportRecordBytes + 1);
  EXPECT_THAT(Parse(huge).status.message(), HasSubstr("exceeds the limit"));
}

}  // namespace
}  // namespace skimap::server
