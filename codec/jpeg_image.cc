// JPEG with libjpeg-turbo's TurboJPEG API: decoded straight into the mode's pixel format
// (grey from a colour JPEG is its luminance, as libjpeg gives it), encoded with 4:2:0
// chroma (4:0:0 for grey), libjpeg's defaults as OpenCV used them.
#include <turbojpeg.h>

#include <algorithm>

#include "absl/strings/str_cat.h"
#include "codec/image_formats.h"

namespace skimap::perception::image_formats {
namespace {

// One handle per thread and direction (created on first use, destroyed with the thread):
// a TurboJPEG handle is not thread-safe.
struct Handle {
  explicit Handle(tjhandle h) : h(h) {}
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  ~Handle() {
    if (h != nullptr) tjDestroy(h);
  }
  tjhandle h;
};

tjhandle Decompressor() {
  thread_local Handle handle(tjInitDecompress());
  return handle.h;
}

tjhandle Compressor() {
  thread_local Handle handle(tjInitCompress());
  return handle.h;
}

}  // namespace

absl::Status DecodeJpeg(std::string_view bytes, ImageMode mode, cv::Mat* out) {
  tjhandle h = Decompressor();
  if (h == nullptr) return absl::InternalError("JPEG: cannot create a decoder");
  const auto* data = reinterpret_cast<const unsigned char*>(bytes.data());
  const auto size = static_cast<unsigned long>(bytes.size());
  int width = 0, height = 0, subsampling = 0, colorspace = 0;
  if (tjDecompressHeader3(h, data, size, &width, &height, &subsampling, &colorspace) != 0) {
    return absl::InvalidArgumentError(absl::StrCat("JPEG: ", tjGetErrorStr2(h)));
  }
  if (absl::Status s = CheckPixels("JPEG", width, height); !s.ok()) return s;
  if (colorspace == TJCS_CMYK || colorspace == TJCS_YCCK) {
    return absl::InvalidArgumentError("JPEG: CMYK images are not supported");
  }
  const bool grey_in = colorspace == TJCS_GRAY;
  int format = TJPF_BGR;
  if (mode == ImageMode::kRgb) {
    format = TJPF_RGB;
  } else if (mode == ImageMode::kGrey || mode == ImageMode::kAnyDepth ||
             (mode == ImageMode::kUnchanged && grey_in)) {
    format = TJPF_GRAY;
  }
  out->create(height, width, format == TJPF_GRAY ? CV_8UC1 : CV_8UC3);
  // A warning (a truncated file: the missing rows grey; bytes after the image) still
  // leaves every pixel written, as libjpeg does for OpenCV; an error refuses the image.
  if (tjDecompress2(h, data, size, out->data, width, static_cast<int>(out->step[0]), height, format,
                    /*flags=*/0) != 0 &&
      tjGetErrorCode(h) != TJERR_WARNING) {
    return absl::InvalidArgumentError(absl::StrCat("JPEG: ", tjGetErrorStr2(h)));
  }
  return absl::OkStatus();
}

absl::StatusOr<std::string> EncodeJpeg(const cv::Mat& image, int quality) {
  if (image.depth() != CV_8U || (image.channels() != 1 && image.channels() != 3) || image.empty()) {
    return absl::InvalidArgumentError("JPEG: holds 8-bit images of 1 or 3 channels, not this one");
  }
  tjhandle h = Compressor();
  if (h == nullptr) return absl::InternalError("JPEG: cannot create an encoder");
  const bool grey = image.channels() == 1;
  unsigned char* buffer = nullptr;
  unsigned long size = 0;
  const int rc =
      tjCompress2(h, image.data, image.cols, static_cast<int>(image.step[0]), image.rows,
                  grey ? TJPF_GRAY : TJPF_BGR, &buffer, &size, grey ? TJSAMP_GRAY : TJSAMP_420,
                  std::clamp(quality, 1, 100), /*flags=*/0);
  std::string out;
  if (rc == 0) out.assign(reinterpret_cast<const char*>(buffer), size);
  tjFree(buffer);
  if (rc != 0) return absl::InternalError(absl::StrCat("JPEG: ", tjGetErrorStr2(h)));
  return out;
}

}  // namespace skimap::perception::image_formats
