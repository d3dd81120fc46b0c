#include "client/frame_depth.h"

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "codec/image_files.h"
#include "codec/rvl_codec.h"
#include "codec/zstd_frame.h"

namespace skimap::client {

absl::Status SetFrameDepth(const uint16_t* pixels, int width, int height, v1::Frame* frame,
                           v1::DepthEncoding encoding) {
  if (width < 1 || height < 1 || width > 8192 || height > 8192) {
    return absl::InvalidArgumentError(
        absl::StrCat("depth: image size ", width, "x", height, " outside 1..8192"));
  }
  const size_t count = size_t(width) * size_t(height);
  std::string bytes;
  switch (encoding) {
    case v1::DEPTH_ENCODING_RVL:
      bytes = perception::EncodeRvl(pixels, count);
      break;
    case v1::DEPTH_ENCODING_RAW_U16:
    case v1::DEPTH_ENCODING_ZSTD:
      bytes.resize(count * 2);
      for (size_t i = 0; i < count; ++i) {
        bytes[2 * i] = static_cast<char>(pixels[i] & 0xff);
        bytes[2 * i + 1] = static_cast<char>(pixels[i] >> 8);
      }
      if (encoding == v1::DEPTH_ENCODING_ZSTD) {
        // One frame that declares its content size (the server checks it: docs/api.md).
        absl::StatusOr<std::string> packed = perception::ZstdCompress(bytes);
        if (!packed.ok()) {
          return absl::InternalError(absl::StrCat("depth: ", packed.status().message()));
        }
        bytes = *std::move(packed);
      }
      break;
    case v1::DEPTH_ENCODING_PNG16: {
      const cv::Mat m(height, width, CV_16UC1, const_cast<uint16_t*>(pixels));
      absl::StatusOr<std::string> png = perception::EncodeImage(".png", m, {.png_compression = 1});
      if (!png.ok()) return absl::InternalError("depth: PNG encoding failed");
      bytes = *std::move(png);
      break;
    }
    default:
      return absl::InvalidArgumentError(
          absl::StrCat("depth_encoding: ", v1::DepthEncoding_Name(encoding),
                       " is not written by the client library (ZSTD, RVL, PNG16 or RAW_U16)"));
  }
  frame->set_depth_encoding(encoding);
  frame->set_depth(std::move(bytes));
  return absl::OkStatus();
}

}  // namespace skimap::client
