// PNG with libpng's classic API. libpng reports errors by longjmp to the setjmp of the
// call in progress: each step that may fail runs in its own small function (ReadHeader,
// ReadRows, WriteAll) whose only locals are plain values, so a longjmp never skips a C++
// destructor; buffers live in the callers, and libpng's structures are released by a guard
// created before any step runs.
#include <png.h>

#include <algorithm>
#include <csetjmp>
#include <cstdio>
#include <cstring>
#include <vector>

#include "absl/strings/str_cat.h"
#include "codec/image_formats.h"

namespace skimap::perception::image_formats {
namespace {

struct ErrorText {
  char text[160] = "";
};

void OnError(png_structp png, png_const_charp message) {
  auto* error = static_cast<ErrorText*>(png_get_error_ptr(png));
  std::snprintf(error->text, sizeof error->text, "%s", message);
  png_longjmp(png, 1);
}

void OnWarning(png_structp, png_const_charp) {}

struct Source {
  const unsigned char* data;
  size_t size, at;
};

void ReadFromSource(png_structp png, png_bytep out, size_t n) {
  auto* source = static_cast<Source*>(png_get_io_ptr(png));
  if (n > source->size - source->at) png_error(png, "file cut short");
  std::memcpy(out, source->data + source->at, n);
  source->at += n;
}

struct Shape {
  png_uint_32 width = 0, height = 0;
  int channels = 0, bit_depth = 0;
};

// Reads the header and sets the transforms that turn the stored pixels into `mode`.
bool ReadHeader(png_structp png, png_infop info, ImageMode mode, Shape* shape) {
  if (setjmp(png_jmpbuf(png))) return false;
  png_set_user_limits(png, 1u << 20, 1u << 20);
  png_read_info(png, info);
  const int color_type = png_get_color_type(png, info);
  const int bit_depth = png_get_bit_depth(png, info);
  const bool keep_depth = mode == ImageMode::kUnchanged || mode == ImageMode::kAnyDepth;
  const bool colour_out =
      mode == ImageMode::kColor || mode == ImageMode::kRgb || mode == ImageMode::kUnchanged;
  // Palette -> RGB (its tRNS -> alpha), grey 1/2/4 -> 8 bit. A tRNS chunk of a grey or RGB
  // image stays ignored, as OpenCV ignores it.
  const bool palette = color_type == PNG_COLOR_TYPE_PALETTE;
  const bool palette_alpha = palette && png_get_valid(png, info, PNG_INFO_tRNS) != 0;
  if (palette) png_set_palette_to_rgb(png);
  if (palette_alpha) png_set_tRNS_to_alpha(png);
  if (color_type == PNG_COLOR_TYPE_GRAY && bit_depth < 8) png_set_expand_gray_1_2_4_to_8(png);
  if (bit_depth == 16) {
    if (keep_depth) {
      png_set_swap(png);  // samples in host (little-endian) order
    } else {
      png_set_strip_16(png);  // the high byte
    }
  }
  const bool has_alpha = (color_type & PNG_COLOR_MASK_ALPHA) != 0 || palette_alpha;
  if (mode != ImageMode::kUnchanged && has_alpha) png_set_strip_alpha(png);
  const bool grey = (color_type & PNG_COLOR_MASK_COLOR) == 0;
  if (colour_out) {
    if (grey && (mode != ImageMode::kUnchanged || has_alpha)) png_set_gray_to_rgb(png);
    if (mode != ImageMode::kRgb) png_set_bgr(png);
  } else if (!grey) {
    png_set_rgb_to_gray_fixed(png, /*error_action=*/1, 29900, 58700);
  }
  png_set_interlace_handling(png);
  png_read_update_info(png, info);
  shape->width = png_get_image_width(png, info);
  shape->height = png_get_image_height(png, info);
  shape->channels = png_get_channels(png, info);
  shape->bit_depth = png_get_bit_depth(png, info);
  return true;
}

bool ReadRows(png_structp png, png_bytepp rows) {
  if (setjmp(png_jmpbuf(png))) return false;
  png_read_image(png, rows);
  return true;
}

struct Sink {
  std::string* out;
};

void WriteToSink(png_structp png, png_bytep data, size_t n) {
  static_cast<Sink*>(png_get_io_ptr(png))->out->append(reinterpret_cast<const char*>(data), n);
}

void Flush(png_structp) {}

bool WriteAll(png_structp png, png_infop info, const cv::Mat& image, int compression,
              png_bytepp rows) {
  if (setjmp(png_jmpbuf(png))) return false;
  const int channels = image.channels();
  const int color_type = channels == 1   ? PNG_COLOR_TYPE_GRAY
                         : channels == 3 ? PNG_COLOR_TYPE_RGB
                                         : PNG_COLOR_TYPE_RGB_ALPHA;
  png_set_IHDR(png, info, image.cols, image.rows, image.depth() == CV_16U ? 16 : 8, color_type,
               PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_set_compression_level(png, compression);
  png_write_info(png, info);
  if (channels >= 3) png_set_bgr(png);
  if (image.depth() == CV_16U) png_set_swap(png);
  png_write_image(png, rows);
  png_write_end(png, info);
  return true;
}

}  // namespace

absl::Status DecodePng(std::string_view bytes, ImageMode mode, cv::Mat* out) {
  if (DecodePngFast(bytes, mode, out)) return absl::OkStatus();
  return DecodePngWithLibpng(bytes, mode, out);
}

absl::Status DecodePngWithLibpng(std::string_view bytes, ImageMode mode, cv::Mat* out) {
  ErrorText error;
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &error, OnError, OnWarning);
  if (png == nullptr) return absl::InternalError("PNG: cannot create a decoder");
  png_infop info = png_create_info_struct(png);
  struct Release {
    png_structp* png;
    png_infop* info;
    ~Release() { png_destroy_read_struct(png, info, nullptr); }
  } release{&png, &info};
  if (info == nullptr) return absl::InternalError("PNG: cannot create a decoder");
  Source source{reinterpret_cast<const unsigned char*>(bytes.data()), bytes.size(), 0};
  png_set_read_fn(png, &source, ReadFromSource);
  Shape shape;
  if (!ReadHeader(png, info, mode, &shape)) {
    return absl::InvalidArgumentError(absl::StrCat("PNG: ", error.text));
  }
  if (absl::Status s = CheckPixels("PNG", shape.width, shape.height); !s.ok()) return s;
  out->create(static_cast<int>(shape.height), static_cast<int>(shape.width),
              CV_MAKETYPE(shape.bit_depth == 16 ? CV_16U : CV_8U, shape.channels));
  std::vector<png_bytep> rows(shape.height);
  for (png_uint_32 r = 0; r < shape.height; ++r) rows[r] = out->ptr(static_cast<int>(r));
  if (!ReadRows(png, rows.data())) {
    return absl::InvalidArgumentError(absl::StrCat("PNG: ", error.text));
  }
  return absl::OkStatus();
}

absl::StatusOr<std::string> EncodePng(const cv::Mat& image, int compression) {
  const int channels = image.channels();
  if ((image.depth() != CV_8U && image.depth() != CV_16U) ||
      (channels != 1 && channels != 3 && channels != 4) || image.empty()) {
    return absl::InvalidArgumentError(
        "PNG: holds 8- or 16-bit images of 1, 3 or 4 channels, not this one");
  }
  ErrorText error;
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &error, OnError, OnWarning);
  if (png == nullptr) return absl::InternalError("PNG: cannot create an encoder");
  png_infop info = png_create_info_struct(png);
  struct Release {
    png_structp* png;
    png_infop* info;
    ~Release() { png_destroy_write_struct(png, info); }
  } release{&png, &info};
  if (info == nullptr) return absl::InternalError("PNG: cannot create an encoder");
  std::string out;
  Sink sink{&out};
  png_set_write_fn(png, &sink, WriteToSink, Flush);
  std::vector<png_bytep> rows(image.rows);
  for (int r = 0; r < image.rows; ++r) rows[r] = const_cast<png_bytep>(image.ptr(r));
  if (!WriteAll(png, info, image, std::clamp(compression, 0, 9), rows.data())) {
    return absl::InternalError(absl::StrCat("PNG: ", error.text));
  }
  return out;
}

}  // namespace skimap::perception::image_formats
