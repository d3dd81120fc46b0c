#include "codec/image_codec.h"

#include <bit>
#include <cstring>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "absl/strings/str_cat.h"
#include "codec/image_files.h"
#include "codec/image_header.h"
#include "codec/rvl_codec.h"
#include "codec/zstd_frame.h"

namespace skimap::perception {
namespace {

constexpr int kMaxSide = 8192;

absl::Status CheckSize(const char* what, int width, int height) {
  if (width <= 0 || height <= 0 || width > kMaxSide || height > kMaxSide) {
    return absl::InvalidArgumentError(
        absl::StrCat(what, ": image size ", width, "x", height, " outside 1..", kMaxSide));
  }
  return absl::OkStatus();
}

absl::Status SizeMismatch(const char* what, int got_w, int got_h, int width, int height) {
  return absl::InvalidArgumentError(absl::StrCat(what, ": decoded image is ", got_w, "x", got_h,
                                                 ", expected ", width, "x", height));
}

// Reads the header of a PNG / JPEG and checks that it claims width x height pixels before
// any decoder sizes a buffer from it.
absl::StatusOr<ImageHeader> CheckHeader(const char* what, ImageFormat format,
                                        std::string_view bytes, int width, int height) {
  absl::StatusOr<ImageHeader> h =
      ReadImageHeader(format, absl::string_view(bytes.data(), bytes.size()), what);
  if (!h.ok()) return h.status();
  if (h->width != width || h->height != height) {
    return absl::InvalidArgumentError(absl::StrCat(what, ": image header claims ", h->width, "x",
                                                   h->height, ", expected ", width, "x", height));
  }
  return h;
}

// Decodes bytes whose header was checked into the width x height `type` pixels at `data`
// (the caller's buffer, sized for them): InvalidArgument "<what>: ..." when they do not
// decode to exactly that.
absl::Status DecodeInPlace(const char* what, std::string_view bytes, ImageMode mode, int width,
                           int height, int type, void* data) {
  cv::Mat m(height, width, type, data);
  if (absl::Status s = DecodeImageInto(bytes, mode, &m); !s.ok()) {
    return absl::InvalidArgumentError(absl::StrCat(what, ": ", s.message()));
  }
  if (m.cols != width || m.rows != height) return SizeMismatch(what, m.cols, m.rows, width, height);
  if (m.type() != type || m.data != data) {
    return absl::InvalidArgumentError(absl::StrCat(what, ": decoded to another pixel type"));
  }
  return absl::OkStatus();
}

void LoadLittleEndian(std::string_view bytes, std::vector<uint16_t>* out) {
  out->resize(bytes.size() / 2);
  const auto* p = reinterpret_cast<const uint8_t*>(bytes.data());
  for (size_t i = 0; i < out->size(); ++i) (*out)[i] = uint16_t(p[2 * i] | (p[2 * i + 1] << 8));
}

std::string StoreLittleEndian(const std::vector<uint16_t>& pixels) {
  std::string out(pixels.size() * 2, '\0');
  for (size_t i = 0; i < pixels.size(); ++i) {
    out[2 * i] = static_cast<char>(pixels[i] & 0xff);
    out[2 * i + 1] = static_cast<char>(pixels[i] >> 8);
  }
  return out;
}

}  // namespace

absl::Status DecodeDepthInto(DepthCodec codec, std::string_view bytes, int width, int height,
                             DepthImage* out) {
  if (absl::Status s = CheckSize("depth", width, height); !s.ok()) return s;
  const size_t count = size_t(width) * size_t(height);
  const size_t raw_bytes = count * 2;
  out->width = width;
  out->height = height;
  switch (codec) {
    case DepthCodec::kRawU16:
      if (bytes.size() != raw_bytes) {
        return absl::InvalidArgumentError(absl::StrCat("depth: raw uint16 image has ", bytes.size(),
                                                       " bytes, expected ", raw_bytes));
      }
      LoadLittleEndian(bytes, &out->pixels);
      return absl::OkStatus();
    case DepthCodec::kZstd: {
      // The claimed size is checked before the pixels are allocated.
      absl::Status s = ZstdCheckFrame(bytes, raw_bytes);
      // The little-endian bytes straight into the pixels, then swapped on a big-endian host.
      if (s.ok()) {
        out->pixels.resize(count);
        s = ZstdDecompressExact(bytes, out->pixels.data(), raw_bytes);
      }
      if (!s.ok()) return absl::InvalidArgumentError(absl::StrCat("depth: ", s.message()));
      if constexpr (std::endian::native == std::endian::big) {
        for (uint16_t& p : out->pixels) p = static_cast<uint16_t>(p << 8 | p >> 8);
      }
      return absl::OkStatus();
    }
    case DepthCodec::kRvl:
      out->pixels.resize(count);
      return DecodeRvl(bytes, out->pixels.data(), count);
    case DepthCodec::kPng16: {
      if (bytes.empty()) return absl::InvalidArgumentError("depth: empty PNG");
      absl::StatusOr<ImageHeader> h = CheckHeader("depth", ImageFormat::kPng, bytes, width, height);
      if (!h.ok()) return h.status();
      if (h->bit_depth != 16 || h->channels != 1) {
        return absl::InvalidArgumentError(absl::StrCat("depth: PNG must be 16-bit greyscale, got ",
                                                       h->bit_depth, "-bit with ", h->channels,
                                                       " channel(s)"));
      }
      out->pixels.resize(count);
      return DecodeInPlace("depth", bytes, ImageMode::kAnyDepth, width, height, CV_16UC1,
                           out->pixels.data());
    }
  }
  return absl::InvalidArgumentError("depth_encoding: unknown codec");
}

absl::StatusOr<DepthImage> DecodeDepth(DepthCodec codec, std::string_view bytes, int width,
                                       int height) {
  DepthImage image;
  if (absl::Status s = DecodeDepthInto(codec, bytes, width, height, &image); !s.ok()) return s;
  return image;
}

absl::Status DecodeColorInto(ColorCodec codec, std::string_view bytes, int width, int height,
                             ColorImage* out) {
  if (absl::Status s = CheckSize("color", width, height); !s.ok()) return s;
  out->width = width;
  out->height = height;
  const size_t raw_bytes = size_t(width) * size_t(height) * 3;
  if (codec == ColorCodec::kRawRgb8) {
    if (bytes.size() != raw_bytes) {
      return absl::InvalidArgumentError(
          absl::StrCat("color: raw RGB image has ", bytes.size(), " bytes, expected ", raw_bytes));
    }
    out->rgb.assign(bytes.begin(), bytes.end());
    return absl::OkStatus();
  }
  if (bytes.empty()) return absl::InvalidArgumentError("color: empty image");
  const bool png = codec == ColorCodec::kPng;
  absl::StatusOr<ImageHeader> h =
      CheckHeader("color", png ? ImageFormat::kPng : ImageFormat::kJpeg, bytes, width, height);
  if (!h.ok()) return h.status();
  // IMREAD_COLOR would quietly scale 16-bit samples down; colour is 8-bit on the wire.
  if (h->bit_depth > 8) {
    return absl::InvalidArgumentError(absl::StrCat("color: ", png ? "PNG" : "JPEG", " has ",
                                                   h->bit_depth, "-bit samples, expected 8-bit"));
  }
  if (!png && h->channels != 1 && h->channels != 3) {
    return absl::InvalidArgumentError(
        absl::StrCat("color: JPEG has ", h->channels, " components, expected 1 or 3"));
  }
  out->rgb.resize(raw_bytes);
  return DecodeInPlace("color", bytes, ImageMode::kRgb, width, height, CV_8UC3, out->rgb.data());
}

absl::StatusOr<ColorImage> DecodeColor(ColorCodec codec, std::string_view bytes, int width,
                                       int height) {
  ColorImage image;
  if (absl::Status s = DecodeColorInto(codec, bytes, width, height, &image); !s.ok()) return s;
  return image;
}

absl::StatusOr<std::string> EncodeDepth(DepthCodec codec, const DepthImage& image) {
  if (absl::Status s = CheckSize("depth", image.width, image.height); !s.ok()) return s;
  if (image.pixels.size() != size_t(image.width) * image.height) {
    return absl::InvalidArgumentError("depth: pixel count differs from width x height");
  }
  switch (codec) {
    case DepthCodec::kRawU16:
      return StoreLittleEndian(image.pixels);
    case DepthCodec::kRvl:
      return EncodeRvl(image.pixels.data(), image.pixels.size());
    case DepthCodec::kZstd:
      return ZstdCompress(StoreLittleEndian(image.pixels));
    case DepthCodec::kPng16: {
      const cv::Mat m(image.height, image.width, CV_16UC1,
                      const_cast<uint16_t*>(image.pixels.data()));
      absl::StatusOr<std::string> png = EncodeImage(".png", m, {.png_compression = 1});
      if (!png.ok()) return absl::InternalError(absl::StrCat("depth: ", png.status().message()));
      return png;
    }
  }
  return absl::InvalidArgumentError("depth: unknown codec");
}

absl::StatusOr<std::string> EncodeColor(ColorCodec codec, const ColorImage& image) {
  if (absl::Status s = CheckSize("color", image.width, image.height); !s.ok()) return s;
  if (image.rgb.size() != size_t(image.width) * image.height * 3) {
    return absl::InvalidArgumentError("color: byte count differs from width x height x 3");
  }
  if (codec == ColorCodec::kRawRgb8) return std::string(image.rgb.begin(), image.rgb.end());
  const cv::Mat rgb(image.height, image.width, CV_8UC3, const_cast<uint8_t*>(image.rgb.data()));
  cv::Mat bgr;
  cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
  absl::StatusOr<std::string> encoded = EncodeImage(
      codec == ColorCodec::kPng ? ".png" : ".jpg", bgr, {.png_compression = 1, .jpeg_quality = 90});
  if (!encoded.ok()) {
    return absl::InternalError(absl::StrCat("color: ", encoded.status().message()));
  }
  return encoded;
}

}  // namespace skimap::perception
