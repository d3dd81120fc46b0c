// Image bytes and image files as OpenCV matrices: PNG (libpng; the common layouts inflated
// with libdeflate, codec/png_fast_path.cc), JPEG (libjpeg-turbo), WebP (libwebp), TIFF
// (libtiff) and binary PGM / PPM, read and written without OpenCV's imgcodecs module.
//
//   absl::StatusOr<cv::Mat> depth = ReadImageFile(path, ImageMode::kAnyDepth);  // CV_16UC1
//   absl::StatusOr<std::string> png = EncodeImage(".png", bgr);
//
// Why not cv::imread: Debian's libopencv-imgcodecs pulls in GDAL and 138 other shared
// libraries, which every process linking it loads at start (0.13 s of CPU per process,
// 0.2 s under ASan: most of the start of skimapd, the CLI and every test program), and it
// hands any file to whichever of its many decoders claims it. These functions accept only
// the formats above, recognised by their signature (not the name), and refuse an image
// claiming more than kMaxImagePixels before anything is allocated for it.
//
// Pixels follow OpenCV's conventions, so the matrices go straight into cv:: functions:
// colour as BGR (BGRA with alpha), 16-bit samples as CV_16U in host order. The modes are
// those of cv::imread:
//   kUnchanged  as stored: 8 or 16 bit (TIFF: also 32-bit float), 1, 3 or 4 channels
//               (a grey + alpha PNG becomes BGRA); palettes expanded
//   kColor      8-bit BGR (16-bit samples: the high byte; alpha dropped)
//   kRgb        as kColor, in R G B order (wire images)
//   kGrey       8-bit, one channel (colour: 0.299 R + 0.587 G + 0.114 B)
//   kAnyDepth   one channel at the stored depth (depth images: 16-bit grey PNG -> CV_16UC1)
// Not done: EXIF orientation of JPEGs (pixels as stored), CMYK JPEGs, tiled TIFFs.
//
// Thread safety: free functions; safe from any thread (each thread its own JPEG handles).
#ifndef CODEC_IMAGE_FILES_H_
#define CODEC_IMAGE_FILES_H_

#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <string_view>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace skimap::perception {

enum class ImageMode { kUnchanged, kColor, kRgb, kGrey, kAnyDepth };

// 2^27 pixels (e.g. 16384 x 8192): larger images are refused from their header.
inline constexpr int64_t kMaxImagePixels = int64_t{1} << 27;
// 1 GiB: a raw 16-bit PPM of kMaxImagePixels is 768 MiB; a larger file is refused unread.
inline constexpr int64_t kMaxImageFileBytes = int64_t{1} << 30;

// Decodes PNG, JPEG, WebP or PGM/PPM bytes into *out. *out is reallocated only when its size
// or type differs from the result, so a matrix over a caller's buffer of the right size and
// type is filled in place. InvalidArgument naming the format when the bytes are not an
// image of these formats, do not decode, or are too large; *out is then unspecified.
absl::Status DecodeImageInto(std::string_view bytes, ImageMode mode, cv::Mat* out);
absl::StatusOr<cv::Mat> DecodeImage(std::string_view bytes, ImageMode mode);

// Reads the file at `path` (the formats of DecodeImage, and TIFF). NotFound if it cannot
// be opened, InvalidArgument "<path>: ..." if it does not decode or is larger than
// kMaxImageFileBytes.
absl::StatusOr<cv::Mat> ReadImageFile(const std::string& path, ImageMode mode);

struct ImageEncoding {
  int png_compression = 1;  // zlib level 0-9 (1: fast, OpenCV's default)
  int jpeg_quality = 95;    // 1-100 (OpenCV's default)
};

// Encodes `image` in the format its extension names: ".png" (8/16-bit, 1/3/4 channels),
// ".jpg"/".jpeg" (8-bit, 1 or 3 channels), ".pgm" (8/16-bit, 1 channel), ".ppm" (8-bit,
// 3 channels). InvalidArgument for another extension or a pixel type the format cannot hold.
absl::StatusOr<std::string> EncodeImage(std::string_view extension, const cv::Mat& image,
                                        const ImageEncoding& encoding = {});

// Writes `image` to `path` in the format its extension names: those of EncodeImage, and
// ".tif"/".tiff" (LZW; 1 channel of 8/16-bit or 32-bit float, or 8-bit BGR). Internal if
// the file cannot be written.
absl::Status WriteImageFile(const std::string& path, const cv::Mat& image,
                            const ImageEncoding& encoding = {});

}  // namespace skimap::perception

#endif  // CODEC_IMAGE_FILES_H_
