#include "codec/zstd_frame.h"

#include <zstd.h>

#include <memory>

#include "absl/strings/str_cat.h"

namespace skimap::perception {

absl::StatusOr<std::string> ZstdCompress(std::string_view raw, int level) {
  thread_local std::unique_ptr<ZSTD_CCtx, size_t (*)(ZSTD_CCtx*)> ctx(ZSTD_createCCtx(),
                                                                      ZSTD_freeCCtx);
  if (ctx == nullptr) return absl::InternalError("zstd: cannot create a context");
  std::string packed(ZSTD_compressBound(raw.size()), '\0');
  const size_t n =
      ZSTD_compressCCtx(ctx.get(), packed.data(), packed.size(), raw.data(), raw.size(), level);
  if (ZSTD_isError(n)) return absl::InternalError(absl::StrCat("zstd: ", ZSTD_getErrorName(n)));
  packed.resize(n);
  return packed;
}

absl::Status ZstdCheckFrame(std::string_view packed, size_t size) {
  const unsigned long long claimed = ZSTD_getFrameContentSize(packed.data(), packed.size());
  if (claimed == ZSTD_CONTENTSIZE_ERROR || claimed == ZSTD_CONTENTSIZE_UNKNOWN) {
    return absl::InvalidArgumentError("not a zstd frame with a known content size");
  }
  if (claimed != size) {
    return absl::InvalidArgumentError(
        absl::StrCat("zstd frame holds ", claimed, " bytes, expected ", size));
  }
  return absl::OkStatus();
}

absl::Status ZstdDecompressExact(std::string_view packed, void* out, size_t size) {
  if (absl::Status s = ZstdCheckFrame(packed, size); !s.ok()) return s;
  const size_t n = ZSTD_decompress(out, size, packed.data(), packed.size());
  if (ZSTD_isError(n) || n != size) {
    return absl::InvalidArgumentError(
        absl::StrCat("zstd decode failed: ", ZSTD_isError(n) ? ZSTD_getErrorName(n) : "short"));
  }
  return absl::OkStatus();
}

}  // namespace skimap::perception
