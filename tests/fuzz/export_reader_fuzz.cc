// Fuzz target: the export file reader (server/core/transfer/map_export.h), fed in pieces.
//
// Input: u8 flags (bit 0: recompute every checksum first, so mutations reach the record
// parsers behind the CRCs), u8 piece seed (how the file is split into Feed calls), then
// the file. The reader must answer every record or an error with a message, keep
// answering the same error afterwards, and never accept a file whose end record it has not
// read.
#include <cstdint>
#include <string>

#include "server/core/transfer/map_export.h"
#include "tests/fuzz/fuzz_input.h"

namespace skimap::fuzz {
namespace {

void PutCrc(std::string* s, size_t at, uint32_t crc) {
  for (int i = 0; i < 4; ++i) (*s)[at + i] = static_cast<char>(crc >> (8 * i));
}

uint32_t Le32(const std::string& s, size_t at) {
  uint32_t v = 0;
  for (int i = 0; i < 4; ++i) v |= uint32_t{static_cast<uint8_t>(s[at + i])} << (8 * i);
  return v;
}

// Rewrites the header, record and whole-file checksums of an export file (docs/formats.md,
// "Export file") where the file is long enough to hold them.
void FixExportCrcs(std::string* f) {
  if (f->size() < 10) return;
  const size_t id_len = static_cast<uint8_t>((*f)[8]) | static_cast<uint8_t>((*f)[9]) << 8;
  size_t pos = 10 + id_len;
  if (pos + 4 > f->size()) return;
  PutCrc(f, pos, Crc32c(std::string_view(*f).substr(0, pos)));
  pos += 4;
  while (pos + 5 <= f->size()) {
    const uint8_t type = static_cast<uint8_t>((*f)[pos]);
    const uint64_t len = Le32(*f, pos + 1);
    if (pos + 5 + len + 4 > f->size()) return;
    if (type == 4 && len == 20) {  // the end record's CRC of everything before it
      PutCrc(f, pos + 5 + 16, Crc32c(std::string_view(*f).substr(0, pos)));
    }
    PutCrc(f, pos + 5 + len, Crc32c(std::string_view(*f).substr(pos, 5 + len)));
    pos += 5 + len + 4;
  }
}

}  // namespace
}  // namespace skimap::fuzz

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace skimap::fuzz;
  FuzzInput in(data, size);
  const uint8_t flags = in.U8();
  uint32_t seed = in.U8() * 2654435761u + 1;
  std::string file(in.Rest());
  if (flags & 1) FixExportCrcs(&file);

  skimap::server::ExportReader reader;
  size_t fed = 0;
  bool ended = false;
  absl::Status error;
  while (error.ok()) {
    if (fed < file.size()) {
      seed = seed * 1103515245u + 12345u;
      const size_t piece = std::min<size_t>(file.size() - fed, 1 + (seed >> 16) % 4096);
      reader.Feed(std::string_view(file).substr(fed, piece));
      fed += piece;
    }
    for (;;) {
      absl::StatusOr<std::optional<skimap::server::ExportRecord>> r = reader.Next();
      if (!r.ok()) {
        error = r.status();
        break;
      }
      if (!r->has_value()) break;
      if (std::holds_alternative<skimap::server::ExportEnd>(**r)) ended = true;
    }
    if (fed == file.size()) break;
  }
  const absl::Status finish = reader.Finish();
  if (!error.ok()) {
    if (error.message().empty()) Fail("an error without a message");
    if (finish.ok()) Fail("Finish is OK after an error");
    absl::StatusOr<std::optional<skimap::server::ExportRecord>> again = reader.Next();
    if (again.ok() || again.status() != error) Fail("the reader forgot its error");
  } else if (finish.ok() && !ended) {
    Fail("a file without its end record was accepted");
  }
  return 0;
}
