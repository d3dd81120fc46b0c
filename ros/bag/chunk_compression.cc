#include "ros/bag/chunk_compression.h"

#include <lz4frame.h>
#include <zstd.h>

#include "absl/strings/str_cat.h"

namespace skimap::bag {

absl::Status DecompressZstd(std::string_view packed, char* out, uint64_t size) {
  const unsigned long long declared = ZSTD_getFrameContentSize(packed.data(), packed.size());
  if (declared == ZSTD_CONTENTSIZE_ERROR) return absl::DataLossError("not a zstd frame");
  if (declared != ZSTD_CONTENTSIZE_UNKNOWN && declared > size) {
    return absl::DataLossError(
        absl::StrCat("zstd frame declares ", declared, " bytes, uncompressed_size ", size));
  }
  const size_t n = ZSTD_decompress(out, size, packed.data(), packed.size());
  if (ZSTD_isError(n)) return absl::DataLossError(absl::StrCat("zstd: ", ZSTD_getErrorName(n)));
  if (n != size) {
    return absl::DataLossError(
        absl::StrCat("zstd: ", n, " bytes decompressed, uncompressed_size ", size));
  }
  return absl::OkStatus();
}

absl::Status DecompressLz4(std::string_view packed, char* out, uint64_t size) {
  LZ4F_dctx* dctx = nullptr;
  if (LZ4F_isError(LZ4F_createDecompressionContext(&dctx, LZ4F_VERSION))) {
    return absl::ResourceExhaustedError("lz4: cannot create a context");
  }
  size_t in_pos = 0, out_pos = 0, hint = 1;
  absl::Status status;
  while (hint != 0) {  // 0: the frame ended
    size_t in_n = packed.size() - in_pos, out_n = size - out_pos;
    hint = LZ4F_decompress(dctx, out + out_pos, &out_n, packed.data() + in_pos, &in_n, nullptr);
    if (LZ4F_isError(hint)) {
      status = absl::DataLossError(absl::StrCat("lz4: ", LZ4F_getErrorName(hint)));
      break;
    }
    in_pos += in_n;
    out_pos += out_n;
    if (hint != 0 && in_n == 0 && out_n == 0) {  // no progress: input ended or output full
      status =
          absl::DataLossError(absl::StrCat("lz4: the frame does not end within ", packed.size(),
                                           " bytes and ", size, " bytes of output"));
      break;
    }
  }
  LZ4F_freeDecompressionContext(dctx);
  if (status.ok() && out_pos != size) {
    status = absl::DataLossError(
        absl::StrCat("lz4: ", out_pos, " bytes decompressed, uncompressed_size ", size));
  }
  return status;
}

}  // namespace skimap::bag
