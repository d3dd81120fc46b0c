// The chunk compressions of MCAP files (mcap_reader.h): one zstd frame, or one LZ4 frame
// (the LZ4 frame format, not a raw block), decompressed into a buffer of exactly the
// chunk's declared uncompressed_size. Input is hostile: a frame that declares more, ends
// early, overruns `size` or yields fewer bytes is DataLoss naming what was wrong; nothing
// is written past out[size).
//
//   absl::Status s = DecompressZstd(packed, buffer.get(), uncompressed_size);
//
// Thread safety: pure functions (each LZ4 call makes its own context).
#ifndef ROS_BAG_CHUNK_COMPRESSION_H_
#define ROS_BAG_CHUNK_COMPRESSION_H_

#include <cstdint>
#include <string_view>

#include "absl/status/status.h"

namespace skimap::bag {

absl::Status DecompressZstd(std::string_view packed, char* out, uint64_t size);
absl::Status DecompressLz4(std::string_view packed, char* out, uint64_t size);

}  // namespace skimap::bag

#endif  // ROS_BAG_CHUNK_COMPRESSION_H_
