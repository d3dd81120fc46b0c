// TIFF files with libtiff: strips (not tiles) of contiguous samples, one channel of 8/16-bit
// unsigned or 32-bit float samples, or 3/4 channels of 8-bit (RGB(A), stored BGR(A) in the
// matrix). Written LZW-compressed, as OpenCV wrote them. libtiff's messages go to a
// handler that drops them (each failure is returned as a status instead).
#include <tiffio.h>

#include <cstdarg>
#include <memory>

#include "absl/strings/str_cat.h"
#include "codec/image_formats.h"
#include "opencv2/imgproc.hpp"

namespace skimap::perception::image_formats {
namespace {

void Quiet(const char*, const char*, va_list) {}

struct Close {
  void operator()(TIFF* t) const { TIFFClose(t); }
};

std::unique_ptr<TIFF, Close> Open(const std::string& path, const char* how) {
  TIFFSetErrorHandler(Quiet);
  TIFFSetWarningHandler(Quiet);
  return std::unique_ptr<TIFF, Close>(TIFFOpen(path.c_str(), how));
}

}  // namespace

absl::Status ReadTiff(const std::string& path, ImageMode mode, cv::Mat* out) {
  std::unique_ptr<TIFF, Close> tiff = Open(path, "r");
  if (tiff == nullptr) return absl::InvalidArgumentError("TIFF: not a readable TIFF file");
  uint32_t width = 0, height = 0;
  uint16_t samples = 1, bits = 8, format = SAMPLEFORMAT_UINT, planar = PLANARCONFIG_CONTIG;
  TIFFGetField(tiff.get(), TIFFTAG_IMAGEWIDTH, &width);
  TIFFGetField(tiff.get(), TIFFTAG_IMAGELENGTH, &height);
  TIFFGetFieldDefaulted(tiff.get(), TIFFTAG_SAMPLESPERPIXEL, &samples);
  TIFFGetFieldDefaulted(tiff.get(), TIFFTAG_BITSPERSAMPLE, &bits);
  TIFFGetFieldDefaulted(tiff.get(), TIFFTAG_SAMPLEFORMAT, &format);
  TIFFGetFieldDefaulted(tiff.get(), TIFFTAG_PLANARCONFIG, &planar);
  if (absl::Status s = CheckPixels("TIFF", width, height); !s.ok()) return s;
  int type = -1;
  if (samples == 1 && bits == 8 && format == SAMPLEFORMAT_UINT) type = CV_8UC1;
  if (samples == 1 && bits == 16 && format == SAMPLEFORMAT_UINT) type = CV_16UC1;
  if (samples == 1 && bits == 32 && format == SAMPLEFORMAT_IEEEFP) type = CV_32FC1;
  if ((samples == 3 || samples == 4) && bits == 8 && format == SAMPLEFORMAT_UINT) {
    type = CV_8UC(samples);
  }
  if (type < 0 || planar != PLANARCONFIG_CONTIG || TIFFIsTiled(tiff.get())) {
    return absl::InvalidArgumentError(absl::StrCat(
        "TIFF: ", samples, " sample(s) of ", bits,
        " bits in this layout are not supported (1 channel of 8/16-bit or float, or 8-bit "
        "RGB(A), in strips)"));
  }
  cv::Mat stored(static_cast<int>(height), static_cast<int>(width), type);
  if (TIFFScanlineSize(tiff.get()) != static_cast<tmsize_t>(stored.cols * stored.elemSize())) {
    return absl::InvalidArgumentError("TIFF: scanline size differs from the image's");
  }
  for (uint32_t r = 0; r < height; ++r) {
    if (TIFFReadScanline(tiff.get(), stored.ptr(static_cast<int>(r)), r) < 0) {
      return absl::InvalidArgumentError(absl::StrCat("TIFF: row ", r, " does not decode"));
    }
  }
  if (samples == 3) cv::cvtColor(stored, stored, cv::COLOR_RGB2BGR);
  if (samples == 4) cv::cvtColor(stored, stored, cv::COLOR_RGBA2BGRA);
  ConvertToMode(stored, mode, out);
  return absl::OkStatus();
}

absl::Status WriteTiff(const std::string& path, const cv::Mat& image) {
  const int depth = image.depth(), channels = image.channels();
  const bool grey = channels == 1 && (depth == CV_8U || depth == CV_16U || depth == CV_32F);
  if (image.empty() || (!grey && !(depth == CV_8U && (channels == 3 || channels == 4)))) {
    return absl::InvalidArgumentError(
        "TIFF: holds one channel of 8/16-bit or float, or 8-bit BGR(A), not this image");
  }
  cv::Mat rows;  // not the caller's pixels: cvtColor would swap them in place
  if (channels == 3) {
    cv::cvtColor(image, rows, cv::COLOR_BGR2RGB);
  } else if (channels == 4) {
    cv::cvtColor(image, rows, cv::COLOR_BGRA2RGBA);
  } else {
    rows = image;
  }
  std::unique_ptr<TIFF, Close> tiff = Open(path, "w");
  if (tiff == nullptr) return absl::InternalError(absl::StrCat("cannot write ", path));
  TIFF* t = tiff.get();
  TIFFSetField(t, TIFFTAG_IMAGEWIDTH, uint32_t(image.cols));
  TIFFSetField(t, TIFFTAG_IMAGELENGTH, uint32_t(image.rows));
  TIFFSetField(t, TIFFTAG_SAMPLESPERPIXEL, uint16_t(channels));
  TIFFSetField(t, TIFFTAG_BITSPERSAMPLE, uint16_t(8 * image.elemSize1()));
  TIFFSetField(t, TIFFTAG_SAMPLEFORMAT,
               uint16_t(depth == CV_32F ? SAMPLEFORMAT_IEEEFP : SAMPLEFORMAT_UINT));
  TIFFSetField(t, TIFFTAG_PHOTOMETRIC, uint16_t(grey ? PHOTOMETRIC_MINISBLACK : PHOTOMETRIC_RGB));
  if (channels == 4) {
    const uint16_t extra = EXTRASAMPLE_UNASSALPHA;
    TIFFSetField(t, TIFFTAG_EXTRASAMPLES, uint16_t(1), &extra);
  }
  TIFFSetField(t, TIFFTAG_PLANARCONFIG, uint16_t(PLANARCONFIG_CONTIG));
  TIFFSetField(t, TIFFTAG_COMPRESSION, uint16_t(COMPRESSION_LZW));
  TIFFSetField(t, TIFFTAG_ROWSPERSTRIP, TIFFDefaultStripSize(t, 0));
  for (int r = 0; r < rows.rows; ++r) {
    if (TIFFWriteScanline(t, const_cast<uchar*>(rows.ptr(r)), uint32_t(r)) < 0) {
      return absl::InternalError(absl::StrCat("cannot write ", path));
    }
  }
  if (TIFFFlush(t) != 1) return absl::InternalError(absl::StrCat("cannot write ", path));
  return absl::OkStatus();
}

}  // namespace skimap::perception::image_formats
