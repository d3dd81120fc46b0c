// One-shot zstd frames, as the API and the map files carry them: one frame per payload,
// its content size declared (every frame ZstdCompress writes), so that a reader checks the
// size before it allocates anything.
//
//   absl::StatusOr<std::string> packed = ZstdCompress(raw);                  // level 1
//   if (absl::Status s = ZstdCheckFrame(*packed, n); !s.ok()) ...            // no allocation
//   std::string out(n, '\0');
//   absl::Status s = ZstdDecompressExact(*packed, out.data(), n);
//
// Errors are InvalidArgument with a message for the caller to put after its field name
// ("depth: " + message), and to turn into its own code (DataLoss for stored data).
//
// Thread safety: thread-safe (compression reuses one context per thread).
#ifndef CODEC_ZSTD_FRAME_H_
#define CODEC_ZSTD_FRAME_H_

#include <cstddef>
#include <string>
#include <string_view>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace skimap::perception {

// `raw` as one zstd frame at `level` (1: fast). Internal ("zstd: ...") if zstd fails.
absl::StatusOr<std::string> ZstdCompress(std::string_view raw, int level = 1);

// OK when `packed` starts a zstd frame that declares exactly `size` bytes.
absl::Status ZstdCheckFrame(std::string_view packed, size_t size);

// `packed` decompressed into out[0, size): OK only when it is one frame that declares
// exactly `size` bytes and holds them (ZstdCheckFrame first, so a bad claim writes nothing).
absl::Status ZstdDecompressExact(std::string_view packed, void* out, size_t size);

}  // namespace skimap::perception

#endif  // CODEC_ZSTD_FRAME_H_
