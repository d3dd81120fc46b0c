// McapReader: reads MCAP files (https://mcap.dev/spec, version 0), the container of ROS 2
// bags (rosbag2's default storage), without ROS. It walks the data section in file order:
// Schema, Channel and Message records, in the data section or inside Chunks (compression
// "", "zstd" or "lz4" = LZ4 frame format, decompressed one chunk at a time into a buffer it
// reuses); every other record (indexes, attachments, metadata, statistics, unknown opcodes)
// is skipped by its length. The summary section serves Channels() only.
//
//   auto reader = McapReader::Open("run.mcap");
//   if (!reader.ok()) return reader.status();
//   absl::Status s = (*reader)->ForEachMessage({"/tf"}, [](const McapMessage& m) {
//     ... m.channel->schema_name, m.log_time_ns, m.data (CDR for ROS 2) ...
//     return absl::OkStatus();
//   });
//
// Errors name the file, the offset of the offending record and its opcode (and the topic
// when known): DataLoss for damaged data (a truncated record, a length past its end, a CRC
// mismatch, a message on an unknown channel, a file without its Footer); InvalidArgument for
// what this reader refuses (an unsupported compression, a chunk over max_chunk_bytes).
// Checked CRCs: a chunk's uncompressed_crc and the DataEnd record's data_section_crc, each
// when non-zero (zero means "not computed"). The data section CRC can only be checked at
// DataEnd, that is after the messages before it were delivered. Attachment and summary CRCs
// are not checked.
//
// Thread safety: not thread-safe; one call at a time per reader. Calls keep no state between
// them, so any number of readers may read the same file (or bytes) at once.
#ifndef ROS_BAG_MCAP_READER_H_
#define ROS_BAG_MCAP_READER_H_

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace skimap::bag {

// One Channel record with its Schema's name and encoding (empty for schema id 0).
struct McapChannel {
  uint16_t id = 0;
  std::string topic, message_encoding;       // message_encoding "cdr" for ROS 2
  std::string schema_name, schema_encoding;  // "sensor_msgs/msg/Image", "ros2msg"
};

// One Message record, as ForEachMessage hands it to its callback.
struct McapMessage {
  const McapChannel* channel = nullptr;  // valid during the callback only
  uint32_t sequence = 0;
  uint64_t log_time_ns = 0, publish_time_ns = 0;
  std::string_view data;       // valid during the callback only
  uint64_t record_offset = 0;  // of the Message record (or of its Chunk) in the file
};

// McapReader::Options (declared here so that `Options options = {}` works in the class).
struct McapReaderOptions {
  // Largest uncompressed chunk the reader allocates; a chunk claiming more is refused
  // (InvalidArgument) before anything is allocated.
  uint64_t max_chunk_bytes = 1ull << 30;
};

class McapReader {
 public:
  using Options = McapReaderOptions;

  // Maps the file at `path` read-only (for the reader's lifetime). NotFound when it does not
  // exist, InvalidArgument when it does not start with the MCAP magic; both name the path.
  [[nodiscard]] static absl::StatusOr<std::unique_ptr<McapReader>> Open(const std::string& path,
                                                                        Options options = {});
  // Reads `bytes`, which the caller keeps alive for the reader's lifetime (tests, fuzzing).
  // `name` stands for the file in errors. InvalidArgument without the MCAP magic.
  [[nodiscard]] static absl::StatusOr<std::unique_ptr<McapReader>> FromBytes(std::string_view bytes,
                                                                             std::string name,
                                                                             Options options = {});

  ~McapReader();
  McapReader(const McapReader&) = delete;
  McapReader& operator=(const McapReader&) = delete;

  // Calls fn for every Message record in file order (chunks in file order, the records of a
  // chunk in their order) whose channel's topic is in `topics` (every message when `topics`
  // is empty). Stops at the first problem (see the file comment), or at the first non-OK
  // status fn returns, which it returns unchanged. OK once the DataEnd or Footer record is
  // reached with every check passed.
  [[nodiscard]] absl::Status ForEachMessage(
      const std::vector<std::string>& topics,
      const std::function<absl::Status(const McapMessage&)>& fn);

  // Every channel in the file, by id: from the summary section when it has Channel records,
  // else by walking the data section (decompressing every chunk). Errors as ForEachMessage.
  [[nodiscard]] absl::StatusOr<std::vector<McapChannel>> Channels();

 private:
  struct Mapping;  // an mmap'ed file, unmapped by the destructor
  McapReader(std::string_view bytes, std::string name, Options options,
             std::unique_ptr<Mapping> mapping);

  std::string_view bytes_;
  std::string name_;
  Options options_;
  std::unique_ptr<Mapping> mapping_;  // null for FromBytes
};

}  // namespace skimap::bag

#endif  // ROS_BAG_MCAP_READER_H_
