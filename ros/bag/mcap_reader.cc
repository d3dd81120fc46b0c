#include "ros/bag/mcap_reader.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <map>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "base/echo.h"
#include "ros/bag/chunk_compression.h"

namespace skimap::bag {
namespace {

constexpr std::string_view kMagic("\x89MCAP0\r\n", 8);
constexpr size_t kRecordHeader = 9;  // opcode u8 + content length u64
constexpr size_t kFooterContent = 20;

enum Opcode : uint8_t {
  kHeader = 0x01,
  kFooter = 0x02,
  kSchema = 0x03,
  kChannel = 0x04,
  kMessage = 0x05,
  kChunk = 0x06,
  kDataEnd = 0x0F,
};

std::string OpcodeName(uint8_t op) {
  static constexpr const char* kNames[] = {
      "",         "Header",        "Footer",        "Schema",     "Channel",         "Message",
      "Chunk",    "MessageIndex",  "ChunkIndex",    "Attachment", "AttachmentIndex", "Statistics",
      "Metadata", "MetadataIndex", "SummaryOffset", "DataEnd"};
  const char* name = op > 0 && op < 16 ? kNames[op] : "unknown";
  return absl::StrFormat("opcode 0x%02x %s", op, name);
}

// Little-endian fields of one record's content; every getter returns false when too short.
class Fields {
 public:
  explicit Fields(std::string_view in) : in_(in) {}
  template <typename T>
  bool Int(T* v) {
    if (in_.size() < sizeof(T)) return false;
    T r = 0;
    for (size_t i = 0; i < sizeof(T); ++i) r |= T(static_cast<uint8_t>(in_[i])) << (8 * i);
    in_.remove_prefix(sizeof(T));
    *v = r;
    return true;
  }
  // A u32 (or, with LenT = uint64_t, u64) length-prefixed byte string.
  template <typename LenT = uint32_t>
  bool Bytes(std::string_view* v) {
    LenT n;
    if (!Int(&n) || n > in_.size()) return false;
    *v = in_.substr(0, n);
    in_.remove_prefix(n);
    return true;
  }
  bool String(std::string* v) {
    std::string_view s;
    if (!Bytes(&s)) return false;
    v->assign(s);
    return true;
  }
  std::string_view rest() const { return in_; }

 private:
  std::string_view in_;
};

struct SchemaInfo {
  std::string name, encoding;
};

// One walk over records: the data section, the records of a chunk, or the summary section.
// Keeps the schemas and channels seen, the chunk buffer, and what to do with a message.
class Walker {
 public:
  Walker(std::string_view file, const std::string& name, const McapReader::Options& options)
      : file_(file), name_(name), options_(options) {}

  const std::vector<std::string>* topics = nullptr;  // null or empty: all
  const std::function<absl::Status(const McapMessage&)>* on_message = nullptr;
  std::map<uint16_t, McapChannel> channels;

  // The data section from the end of the leading magic to DataEnd (or Footer).
  absl::Status WalkDataSection() {
    uint64_t pos = kMagic.size();
    while (true) {
      if (pos == file_.size()) {
        return Loss(pos, "", "the file ends here without DataEnd or Footer record (truncated?)");
      }
      uint8_t op;
      std::string_view content;
      if (absl::Status s = Next(file_, &pos, &op, &content, pos, ""); !s.ok()) return s;
      const uint64_t at = pos - kRecordHeader - content.size();
      if (op == kDataEnd) return CheckDataCrc(at, content);
      if (op == kFooter) return absl::OkStatus();
      if (op == kChunk) {
        if (absl::Status s = Chunk(at, content); !s.ok()) return s;
      } else if (absl::Status s = Record(op, content, at, ""); !s.ok()) {
        return s;
      }
    }
  }

  // The records of [begin, end) (the summary section): Schema and Channel records only.
  absl::Status WalkSummary(uint64_t begin, uint64_t end) {
    const std::string_view section = file_.substr(0, end);
    for (uint64_t pos = begin; pos < end;) {
      uint8_t op;
      std::string_view content;
      if (absl::Status s = Next(section, &pos, &op, &content, pos, ""); !s.ok()) return s;
      if (op != kSchema && op != kChannel) continue;
      const uint64_t at = pos - kRecordHeader - content.size();
      if (absl::Status s = Record(op, content, at, ""); !s.ok()) return s;
    }
    return absl::OkStatus();
  }

 private:
  // Where a record is, for errors: "record at offset N (opcode ...)" in the file, or "chunk at
  // offset N, record at byte M of its records (opcode ...)".
  std::string Where(uint64_t at, uint8_t op, absl::string_view chunk) const {
    if (chunk.empty()) return absl::StrCat("record at offset ", at, " (", OpcodeName(op), ")");
    return absl::StrCat(chunk, ", record at byte ", at, " of its records (", OpcodeName(op), ")");
  }
  absl::Status Loss(uint64_t at, absl::string_view chunk, absl::string_view what) const {
    if (chunk.empty()) return absl::DataLossError(absl::StrCat(name_, ": offset ", at, ": ", what));
    return absl::DataLossError(absl::StrCat(name_, ": ", chunk, ", byte ", at, ": ", what));
  }

  // The record at *pos of `in`, whose content must end within `in`; advances *pos past it.
  absl::Status Next(std::string_view in, uint64_t* pos, uint8_t* op, std::string_view* content,
                    uint64_t at, absl::string_view chunk) const {
    const uint64_t left = in.size() - *pos;
    if (left < kRecordHeader) {
      return Loss(at, chunk,
                  absl::StrCat("truncated record: its header needs ", kRecordHeader, " bytes, ",
                               left, " left"));
    }
    Fields f(in.substr(*pos, kRecordHeader));
    uint64_t length;
    f.Int(op);
    f.Int(&length);
    if (length > left - kRecordHeader) {
      return absl::DataLossError(absl::StrCat(name_, ": ", Where(at, *op, chunk), ": declares ",
                                              length, " bytes, ", left - kRecordHeader,
                                              " left (truncated?)"));
    }
    *content = in.substr(*pos + kRecordHeader, length);
    *pos += kRecordHeader + length;
    return absl::OkStatus();
  }

  absl::Status Bad(uint64_t at, uint8_t op, absl::string_view chunk, absl::string_view what) const {
    return absl::DataLossError(absl::StrCat(name_, ": ", Where(at, op, chunk), ": ", what));
  }

  // A Schema, Channel or Message record (others are skipped). `message_offset`: the file
  // offset messages report (the record's, or its chunk's).
  absl::Status Record(uint8_t op, std::string_view content, uint64_t at, absl::string_view chunk,
                      uint64_t message_offset = 0) {
    Fields f(content);
    if (op == kSchema) {
      uint16_t id;
      SchemaInfo schema;
      std::string_view data;
      if (!f.Int(&id) || !f.String(&schema.name) || !f.String(&schema.encoding) ||
          !f.Bytes(&data)) {
        return Bad(at, op, chunk, "truncated Schema fields");
      }
      schemas_[id] = std::move(schema);
    } else if (op == kChannel) {
      McapChannel c;
      uint16_t schema_id;
      std::string_view metadata;
      if (!f.Int(&c.id) || !f.Int(&schema_id) || !f.String(&c.topic) ||
          !f.String(&c.message_encoding) || !f.Bytes(&metadata)) {
        return Bad(at, op, chunk, "truncated Channel fields");
      }
      if (schema_id != 0) {
        auto it = schemas_.find(schema_id);
        if (it == schemas_.end()) {
          return Bad(at, op, chunk,
                     absl::StrCat("channel ", c.id, " (topic ", Echo(c.topic),
                                  ") refers to unknown schema ", schema_id));
        }
        c.schema_name = it->second.name;
        c.schema_encoding = it->second.encoding;
      }
      channels[c.id] = std::move(c);
    } else if (op == kMessage && on_message != nullptr) {
      McapMessage m;
      uint16_t channel_id;
      if (!f.Int(&channel_id) || !f.Int(&m.sequence) || !f.Int(&m.log_time_ns) ||
          !f.Int(&m.publish_time_ns)) {
        return Bad(at, op, chunk, "truncated Message fields");
      }
      auto it = channels.find(channel_id);
      if (it == channels.end()) {
        return Bad(at, op, chunk, absl::StrCat("message on unknown channel ", channel_id));
      }
      if (topics != nullptr && !topics->empty() &&
          std::find(topics->begin(), topics->end(), it->second.topic) == topics->end()) {
        return absl::OkStatus();
      }
      m.channel = &it->second;
      m.data = f.rest();
      m.record_offset = chunk.empty() ? at : message_offset;
      return (*on_message)(m);
    }
    return absl::OkStatus();
  }

  absl::Status Chunk(uint64_t at, std::string_view content) {
    Fields f(content);
    uint64_t start_time, end_time, size;
    uint32_t crc;
    std::string compression;
    std::string_view packed;
    if (!f.Int(&start_time) || !f.Int(&end_time) || !f.Int(&size) || !f.Int(&crc) ||
        !f.String(&compression) || !f.Bytes<uint64_t>(&packed)) {
      return Bad(at, kChunk, "", "truncated Chunk fields");
    }
    const auto refuse = [&](absl::string_view what) {
      return absl::InvalidArgumentError(
          absl::StrCat(name_, ": ", Where(at, kChunk, ""), ": ", what));
    };
    if (size > options_.max_chunk_bytes) {
      return refuse(absl::StrCat("uncompressed_size ", size, " is over the limit of ",
                                 options_.max_chunk_bytes, " bytes"));
    }
    std::string_view records;
    if (compression.empty()) {
      if (packed.size() != size) {
        return Bad(at, kChunk, "",
                   absl::StrCat(packed.size(), " bytes of records, ", size,
                                " declared by uncompressed_size"));
      }
      records = packed;
    } else if (compression == "zstd" || compression == "lz4") {
      if (size > capacity_) {
        buffer_.reset(new char[size]);
        capacity_ = size;
      }
      absl::Status s = compression == "zstd" ? DecompressZstd(packed, buffer_.get(), size)
                                             : DecompressLz4(packed, buffer_.get(), size);
      if (!s.ok()) return Bad(at, kChunk, "", s.message());
      records = std::string_view(buffer_.get(), size);
    } else {
      return refuse(absl::StrCat("unsupported compression ", Echo(compression),
                                 " (known: \"\", \"zstd\", \"lz4\")"));
    }
    if (crc != 0) {
      const uint32_t actual = static_cast<uint32_t>(
          crc32_z(0, reinterpret_cast<const Bytef*>(records.data()), records.size()));
      if (actual != crc) {
        return Bad(at, kChunk, "",
                   absl::StrFormat("CRC mismatch: uncompressed_crc 0x%08x, "
                                   "records have 0x%08x",
                                   crc, actual));
      }
    }
    const std::string where = absl::StrCat("chunk at offset ", at);
    for (uint64_t pos = 0; pos < records.size();) {
      uint8_t op;
      std::string_view record;
      const uint64_t record_at = pos;
      if (absl::Status s = Next(records, &pos, &op, &record, record_at, where); !s.ok()) return s;
      if (absl::Status s = Record(op, record, record_at, where, at); !s.ok()) return s;
    }
    return absl::OkStatus();
  }

  absl::Status CheckDataCrc(uint64_t at, std::string_view content) const {
    Fields f(content);
    uint32_t crc;
    if (!f.Int(&crc)) return Bad(at, kDataEnd, "", "truncated DataEnd fields");
    if (crc == 0) return absl::OkStatus();
    const uint32_t actual =
        static_cast<uint32_t>(crc32_z(0, reinterpret_cast<const Bytef*>(file_.data()), at));
    if (actual != crc) {
      return Bad(at, kDataEnd, "",
                 absl::StrFormat("CRC mismatch: data_section_crc 0x%08x, "
                                 "the data section has 0x%08x",
                                 crc, actual));
    }
    return absl::OkStatus();
  }

  std::string_view file_;
  const std::string& name_;
  const McapReader::Options& options_;
  std::map<uint16_t, SchemaInfo> schemas_;
  std::unique_ptr<char[]> buffer_;  // the current chunk's records, uninitialised past them
  uint64_t capacity_ = 0;
};

}  // namespace

struct McapReader::Mapping {
  void* data = nullptr;
  size_t size = 0;
  ~Mapping() {
    if (data != nullptr) munmap(data, size);
  }
};

McapReader::McapReader(std::string_view bytes, std::string name, Options options,
                       std::unique_ptr<Mapping> mapping)
    : bytes_(bytes), name_(std::move(name)), options_(options), mapping_(std::move(mapping)) {}

McapReader::~McapReader() = default;

absl::StatusOr<std::unique_ptr<McapReader>> McapReader::FromBytes(std::string_view bytes,
                                                                  std::string name,
                                                                  Options options) {
  if (bytes.substr(0, kMagic.size()) != kMagic) {
    return absl::InvalidArgumentError(absl::StrCat(name, ": not an MCAP file (no magic)"));
  }
  return std::unique_ptr<McapReader>(new McapReader(bytes, std::move(name), options, nullptr));
}

absl::StatusOr<std::unique_ptr<McapReader>> McapReader::Open(const std::string& path,
                                                             Options options) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) {
    const int e = errno;
    std::string what = absl::StrCat(path, ": cannot open: ", std::strerror(e));
    return e == ENOENT ? absl::NotFoundError(what) : absl::PermissionDeniedError(what);
  }
  struct stat st {};
  auto mapping = std::make_unique<Mapping>();
  if (::fstat(fd, &st) == 0 && S_ISREG(st.st_mode) && st.st_size >= 0 &&
      static_cast<size_t>(st.st_size) >= kMagic.size()) {
    mapping->size = static_cast<size_t>(st.st_size);
    void* p = ::mmap(nullptr, mapping->size, PROT_READ, MAP_PRIVATE, fd, 0);
    if (p != MAP_FAILED) mapping->data = p;
  }
  ::close(fd);
  if (mapping->data == nullptr) {
    return absl::InvalidArgumentError(
        absl::StrCat(path, ": not an MCAP file (too short, not a regular file, or unmappable)"));
  }
  const std::string_view bytes(static_cast<const char*>(mapping->data), mapping->size);
  if (bytes.substr(0, kMagic.size()) != kMagic) {
    return absl::InvalidArgumentError(absl::StrCat(path, ": not an MCAP file (no magic)"));
  }
  return std::unique_ptr<McapReader>(new McapReader(bytes, path, options, std::move(mapping)));
}

absl::Status McapReader::ForEachMessage(const std::vector<std::string>& topics,
                                        const std::function<absl::Status(const McapMessage&)>& fn) {
  Walker walker(bytes_, name_, options_);
  walker.topics = &topics;
  walker.on_message = &fn;
  return walker.WalkDataSection();
}

absl::StatusOr<std::vector<McapChannel>> McapReader::Channels() {
  Walker walker(bytes_, name_, options_);
  // The summary section, when the file ends with a Footer record and the magic.
  const size_t tail = kRecordHeader + kFooterContent + kMagic.size();
  if (bytes_.size() >= kMagic.size() + tail &&
      bytes_.substr(bytes_.size() - kMagic.size()) == kMagic) {
    const uint64_t footer = bytes_.size() - tail;
    Fields f(bytes_.substr(footer));
    uint8_t op;
    uint64_t length, summary_start;
    if (f.Int(&op) && op == kFooter && f.Int(&length) && length == kFooterContent &&
        f.Int(&summary_start) && summary_start >= kMagic.size() && summary_start <= footer) {
      if (absl::Status s = walker.WalkSummary(summary_start, footer); !s.ok()) return s;
    }
  }
  if (walker.channels.empty()) {
    if (absl::Status s = walker.WalkDataSection(); !s.ok()) return s;
  }
  std::vector<McapChannel> out;
  out.reserve(walker.channels.size());
  for (auto& [id, channel] : walker.channels) out.push_back(std::move(channel));
  return out;
}

}  // namespace skimap::bag
