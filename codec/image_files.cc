#include "codec/image_files.h"

#include <webp/decode.h>

#include <algorithm>
#include <cctype>
#include <fstream>
#include <opencv2/imgproc.hpp>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "codec/image_formats.h"

namespace skimap::perception {
namespace image_formats {

absl::Status CheckPixels(const char* format, int64_t width, int64_t height) {
  if (width <= 0 || height <= 0 || width > kMaxImagePixels / height) {
    return absl::InvalidArgumentError(absl::StrCat(format, ": image size ", width, "x", height,
                                                   " is empty or above ", kMaxImagePixels,
                                                   " pixels"));
  }
  return absl::OkStatus();
}

void ConvertToMode(const cv::Mat& stored, ImageMode mode, cv::Mat* out) {
  if (mode == ImageMode::kUnchanged) {
    stored.copyTo(*out);
    return;
  }
  cv::Mat image = stored;
  if (mode != ImageMode::kAnyDepth && stored.depth() == CV_16U) {
    // The high byte, as libpng's strip_16 gives it.
    cv::Mat high(stored.size(), CV_MAKETYPE(CV_8U, stored.channels()));
    for (int r = 0; r < stored.rows; ++r) {
      const uint16_t* in = stored.ptr<uint16_t>(r);
      uint8_t* o = high.ptr<uint8_t>(r);
      for (size_t i = 0; i < size_t(stored.cols) * stored.channels(); ++i) o[i] = in[i] >> 8;
    }
    image = high;
  } else if (mode != ImageMode::kAnyDepth && stored.depth() != CV_8U) {
    stored.convertTo(image, CV_8U);  // float: rounded and saturated
  }
  const int channels = image.channels();
  if (mode == ImageMode::kColor || mode == ImageMode::kRgb) {
    const bool rgb = mode == ImageMode::kRgb;
    if (channels == 1) {
      cv::cvtColor(image, *out, rgb ? cv::COLOR_GRAY2RGB : cv::COLOR_GRAY2BGR);
    } else if (channels == 4) {
      cv::cvtColor(image, *out, rgb ? cv::COLOR_BGRA2RGB : cv::COLOR_BGRA2BGR);
    } else if (rgb) {
      cv::cvtColor(image, *out, cv::COLOR_BGR2RGB);
    } else {
      image.copyTo(*out);
    }
    return;
  }
  if (channels == 3) {
    cv::cvtColor(image, *out, cv::COLOR_BGR2GRAY);
  } else if (channels == 4) {
    cv::cvtColor(image, *out, cv::COLOR_BGRA2GRAY);
  } else {
    image.copyTo(*out);
  }
}

namespace {

// The next header token of a PNM (after whitespace and # comments) as a number; -1 if none.
int64_t PnmNumber(std::string_view bytes, size_t* at) {
  while (*at < bytes.size()) {
    const char c = bytes[*at];
    if (c == '#') {
      while (*at < bytes.size() && bytes[*at] != '\n') ++*at;
    } else if (std::isspace(static_cast<unsigned char>(c))) {
      ++*at;
    } else {
      break;
    }
  }
  int64_t value = -1;
  while (*at < bytes.size() && std::isdigit(static_cast<unsigned char>(bytes[*at])) &&
         value < (int64_t{1} << 32)) {
    value = std::max<int64_t>(value, 0) * 10 + (bytes[*at] - '0');
    ++*at;
  }
  return value;
}

}  // namespace

absl::Status DecodePnm(std::string_view bytes, ImageMode mode, cv::Mat* out) {
  const bool colour = bytes[1] == '6';
  size_t at = 2;
  const int64_t width = PnmNumber(bytes, &at), height = PnmNumber(bytes, &at),
                maxval = PnmNumber(bytes, &at);
  if (width < 0 || height < 0 || maxval < 1 || maxval > 65535 || at >= bytes.size() ||
      !std::isspace(static_cast<unsigned char>(bytes[at]))) {
    return absl::InvalidArgumentError("PNM: bad header (width, height, maxval 1..65535)");
  }
  ++at;  // the single whitespace before the samples
  if (absl::Status s = CheckPixels("PNM", width, height); !s.ok()) return s;
  const int channels = colour ? 3 : 1, sample_bytes = maxval > 255 ? 2 : 1;
  const size_t row_bytes = size_t(width) * channels * sample_bytes;
  if (bytes.size() - at < row_bytes * height) {
    return absl::InvalidArgumentError(
        absl::StrCat("PNM: ", bytes.size() - at, " bytes of ", row_bytes * height, " samples"));
  }
  cv::Mat stored(int(height), int(width),
                 CV_MAKETYPE(sample_bytes == 2 ? CV_16U : CV_8U, channels));
  const auto* p = reinterpret_cast<const uint8_t*>(bytes.data() + at);
  for (int r = 0; r < stored.rows; ++r, p += row_bytes) {
    if (sample_bytes == 1) {
      std::copy(p, p + row_bytes, stored.ptr<uint8_t>(r));
    } else {
      uint16_t* o = stored.ptr<uint16_t>(r);
      for (size_t i = 0; i < row_bytes / 2; ++i) o[i] = uint16_t(p[2 * i] << 8 | p[2 * i + 1]);
    }
  }
  if (colour) cv::cvtColor(stored, stored, cv::COLOR_RGB2BGR);
  ConvertToMode(stored, mode, out);
  return absl::OkStatus();
}

absl::StatusOr<std::string> EncodePnm(const cv::Mat& image) {
  const int channels = image.channels();
  if (image.empty() || !((channels == 1 && (image.depth() == CV_8U || image.depth() == CV_16U)) ||
                         (channels == 3 && image.depth() == CV_8U))) {
    return absl::InvalidArgumentError(
        "PNM: holds 8/16-bit grey (.pgm) or 8-bit BGR (.ppm) images, not this one");
  }
  const bool wide = image.depth() == CV_16U;
  std::string out = absl::StrCat(channels == 3 ? "P6" : "P5", "\n", image.cols, " ", image.rows,
                                 "\n", wide ? 65535 : 255, "\n");
  cv::Mat rows;  // not the caller's pixels: cvtColor would swap them in place
  if (channels == 3) {
    cv::cvtColor(image, rows, cv::COLOR_BGR2RGB);
  } else {
    rows = image;
  }
  for (int r = 0; r < rows.rows; ++r) {
    if (wide) {
      const uint16_t* in = rows.ptr<uint16_t>(r);
      for (int i = 0; i < rows.cols; ++i) {
        out.push_back(static_cast<char>(in[i] >> 8));
        out.push_back(static_cast<char>(in[i] & 0xff));
      }
    } else {
      const char* in = reinterpret_cast<const char*>(rows.ptr(r));
      out.append(in, size_t(rows.cols) * channels);
    }
  }
  return out;
}

absl::Status DecodeWebp(std::string_view bytes, ImageMode mode, cv::Mat* out) {
  const auto* data = reinterpret_cast<const uint8_t*>(bytes.data());
  WebPBitstreamFeatures features;
  if (WebPGetFeatures(data, bytes.size(), &features) != VP8_STATUS_OK) {
    return absl::InvalidArgumentError("WebP: bad header");
  }
  if (absl::Status s = CheckPixels("WebP", features.width, features.height); !s.ok()) return s;
  const bool alpha = features.has_alpha && mode == ImageMode::kUnchanged;
  cv::Mat stored(features.height, features.width, alpha ? CV_8UC4 : CV_8UC3);
  const size_t size = stored.step[0] * stored.rows;
  const int stride = static_cast<int>(stored.step[0]);
  if ((alpha ? WebPDecodeBGRAInto(data, bytes.size(), stored.data, size, stride)
             : WebPDecodeBGRInto(data, bytes.size(), stored.data, size, stride)) == nullptr) {
    return absl::InvalidArgumentError("WebP: does not decode");
  }
  ConvertToMode(stored, mode, out);
  return absl::OkStatus();
}

}  // namespace image_formats

namespace {

enum class Format { kPng, kJpeg, kWebp, kPnm, kTiff, kUnknown };

Format Recognise(std::string_view b) {
  if (b.size() >= 8 && b.substr(0, 8) == std::string_view("\x89PNG\r\n\x1a\n", 8)) {
    return Format::kPng;
  }
  if (b.size() >= 3 && b.substr(0, 3) == "\xff\xd8\xff") return Format::kJpeg;
  if (b.size() >= 12 && b.substr(0, 4) == "RIFF" && b.substr(8, 4) == "WEBP") {
    return Format::kWebp;
  }
  if (b.size() >= 3 && b[0] == 'P' && (b[1] == '5' || b[1] == '6') &&
      std::isspace(static_cast<unsigned char>(b[2]))) {
    return Format::kPnm;
  }
  if (b.size() >= 4 && (b.substr(0, 4) == std::string_view("II*\0", 4) ||
                        b.substr(0, 4) == std::string_view("MM\0*", 4))) {
    return Format::kTiff;
  }
  return Format::kUnknown;
}

std::string Extension(std::string_view name) {
  const size_t dot = name.rfind('.');
  return dot == std::string_view::npos ? "" : absl::AsciiStrToLower(std::string(name.substr(dot)));
}

}  // namespace

absl::Status DecodeImageInto(std::string_view bytes, ImageMode mode, cv::Mat* out) {
  switch (Recognise(bytes)) {
    case Format::kPng:
      return image_formats::DecodePng(bytes, mode, out);
    case Format::kJpeg:
      return image_formats::DecodeJpeg(bytes, mode, out);
    case Format::kWebp:
      return image_formats::DecodeWebp(bytes, mode, out);
    case Format::kPnm:
      return image_formats::DecodePnm(bytes, mode, out);
    case Format::kTiff:
      return absl::InvalidArgumentError("TIFF: read from files only");
    case Format::kUnknown:
      break;
  }
  return absl::InvalidArgumentError("not a PNG, JPEG, WebP or binary PGM/PPM image");
}

absl::StatusOr<cv::Mat> DecodeImage(std::string_view bytes, ImageMode mode) {
  cv::Mat out;
  if (absl::Status s = DecodeImageInto(bytes, mode, &out); !s.ok()) return s;
  return out;
}

absl::StatusOr<cv::Mat> ReadImageFile(const std::string& path, ImageMode mode) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return absl::NotFoundError(absl::StrCat(path, ": cannot be opened"));
  char head[12] = {};
  in.read(head, sizeof head);
  cv::Mat out;
  absl::Status s;
  if (Recognise(std::string_view(head, static_cast<size_t>(in.gcount()))) == Format::kTiff) {
    s = image_formats::ReadTiff(path, mode, &out);
  } else {
    // One sized read: a per-character copy (istreambuf_iterator) took 12 % of a render's
    // CPU under ASan reading the sim's textures.
    in.clear();
    in.seekg(0, std::ios::end);
    const std::streamoff size = in.tellg();
    if (size < 0) return absl::InternalError(absl::StrCat(path, ": cannot be read"));
    if (size > kMaxImageFileBytes) {
      return absl::InvalidArgumentError(absl::StrCat(
          path, ": ", size, " bytes, more than an image file may hold (", kMaxImageFileBytes, ")"));
    }
    std::string bytes(static_cast<size_t>(size), '\0');
    in.seekg(0);
    in.read(bytes.data(), size);
    if (in.gcount() != size) return absl::InternalError(absl::StrCat(path, ": cannot be read"));
    s = DecodeImageInto(bytes, mode, &out);
  }
  if (!s.ok()) return absl::InvalidArgumentError(absl::StrCat(path, ": ", s.message()));
  return out;
}

absl::StatusOr<std::string> EncodeImage(std::string_view extension, const cv::Mat& image,
                                        const ImageEncoding& encoding) {
  const std::string ext = absl::AsciiStrToLower(std::string(extension));
  if (ext == ".png") return image_formats::EncodePng(image, encoding.png_compression);
  if (ext == ".jpg" || ext == ".jpeg") {
    return image_formats::EncodeJpeg(image, encoding.jpeg_quality);
  }
  if (ext == ".pgm" || ext == ".ppm" || ext == ".pnm") {
    if ((ext == ".pgm") != (image.channels() == 1) && ext != ".pnm") {
      return absl::InvalidArgumentError(
          absl::StrCat(ext, ": ", image.channels(), "-channel image in the wrong PNM kind"));
    }
    return image_formats::EncodePnm(image);
  }
  return absl::InvalidArgumentError(
      absl::StrCat("image format '", ext, "': .png, .jpg, .jpeg, .pgm or .ppm"));
}

absl::Status WriteImageFile(const std::string& path, const cv::Mat& image,
                            const ImageEncoding& encoding) {
  const std::string ext = Extension(path);
  if (ext == ".tif" || ext == ".tiff") return image_formats::WriteTiff(path, image);
  absl::StatusOr<std::string> bytes = EncodeImage(ext, image, encoding);
  if (!bytes.ok()) return bytes.status();
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes->data(), static_cast<std::streamsize>(bytes->size()));
  out.close();
  if (!out) return absl::InternalError(absl::StrCat("cannot write ", path));
  return absl::OkStatus();
}

}  // namespace skimap::perception
