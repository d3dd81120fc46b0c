// One decoder and encoder per image format, behind codec/image_files.h (which picks the
// format from the signature or the extension). Internal to skimap_image_codec.
//
// Decoders take bytes that carry their format's signature and write *out with
// cv::Mat::create (no reallocation when *out already has the result's size and type);
// InvalidArgument "<FORMAT>: ..." when the bytes do not decode or claim more than
// kMaxImagePixels. Encoders refuse a pixel type their format cannot hold.
//
// Thread safety: free functions; safe from any thread.
#ifndef CODEC_IMAGE_FORMATS_H_
#define CODEC_IMAGE_FORMATS_H_

#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <string_view>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "codec/image_files.h"

namespace skimap::perception::image_formats {

// PNG: DecodePngFast (png_fast_path.cc), or libpng when it declines.
absl::Status DecodePng(std::string_view bytes, ImageMode mode, cv::Mat* out);
// libpng alone (the reference the fast path is tested against).
absl::Status DecodePngWithLibpng(std::string_view bytes, ImageMode mode, cv::Mat* out);
// The common layouts (non-interlaced 8/16-bit grey, 8-bit RGB / RGBA; not every mode)
// with libdeflate: true with exactly libpng's pixels in *out, or false (*out unspecified)
// for any other layout or mode and for anything unusual or damaged, which libpng judges.
bool DecodePngFast(std::string_view bytes, ImageMode mode, cv::Mat* out);
absl::Status DecodeJpeg(std::string_view bytes, ImageMode mode, cv::Mat* out);
absl::Status DecodeWebp(std::string_view bytes, ImageMode mode, cv::Mat* out);
absl::Status DecodePnm(std::string_view bytes, ImageMode mode, cv::Mat* out);
absl::Status ReadTiff(const std::string& path, ImageMode mode, cv::Mat* out);

absl::StatusOr<std::string> EncodePng(const cv::Mat& image, int compression);
absl::StatusOr<std::string> EncodeJpeg(const cv::Mat& image, int quality);
absl::StatusOr<std::string> EncodePnm(const cv::Mat& image);
absl::Status WriteTiff(const std::string& path, const cv::Mat& image);

// InvalidArgument "<format>: ..." unless 0 < width, height and width * height <=
// kMaxImagePixels.
absl::Status CheckPixels(const char* format, int64_t width, int64_t height);

// An image decoded as stored (8-bit, 16-bit or 32-bit float; 1, 3 = BGR or 4 = BGRA
// channels) converted to `mode` into *out (see image_files.h; 16 -> 8 bit keeps the high
// byte).
void ConvertToMode(const cv::Mat& stored, ImageMode mode, cv::Mat* out);

}  // namespace skimap::perception::image_formats

#endif  // CODEC_IMAGE_FORMATS_H_
