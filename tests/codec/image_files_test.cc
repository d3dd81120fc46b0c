// Image files (codec/image_files.h) against OpenCV's imgcodecs, the decoder they replaced
// and the reference here (this is the one test program that links it): the real ycbv-0000
// PNGs and the opencv-doc JPEG photographs decode to exactly OpenCV's pixels in every
// mode; PNG layouts OpenCV's writer never makes (palette, transparency, grey + alpha, 1-bit,
// 16-bit colour) decode as OpenCV decodes them; what we encode OpenCV reads back exactly;
// and damaged or oversized images are refused by name, never a crash or a huge allocation.
#include "codec/image_files.h"

#include <gtest/gtest.h>
#include <zlib.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "codec/image_formats.h"

namespace skimap::perception {
namespace {

namespace fs = std::filesystem;

constexpr const char* kDocData = "/usr/share/doc/opencv-doc/examples/data";

struct ModePair {
  ImageMode ours;
  int opencv;
};
const ModePair kModes[] = {{ImageMode::kUnchanged, cv::IMREAD_UNCHANGED},
                           {ImageMode::kColor, cv::IMREAD_COLOR},
                           {ImageMode::kGrey, cv::IMREAD_GRAYSCALE},
                           {ImageMode::kAnyDepth, cv::IMREAD_ANYDEPTH}};

bool Same(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() &&
         (a.empty() || cv::norm(a, b, cv::NORM_INF) == 0);
}

cv::Mat OpenCvDecode(const std::string& bytes, int flags) {
  return cv::imdecode(cv::Mat(1, int(bytes.size()), CV_8UC1, const_cast<char*>(bytes.data())),
                      flags);
}

uint32_t Crc(const std::string& type_and_data) {
  return static_cast<uint32_t>(
      crc32(0, reinterpret_cast<const Bytef*>(type_and_data.data()), type_and_data.size()));
}

std::string Be32(uint32_t v) { return {char(v >> 24), char(v >> 16), char(v >> 8), char(v)}; }

std::string Chunk(const std::string& type, const std::string& data) {
  return Be32(uint32_t(data.size())) + type + data + Be32(Crc(type + data));
}

// A PNG of raw scanlines (filter byte 0 prepended here), with optional PLTE / tRNS chunks.
std::string MakePng(int width, int height, int bit_depth, int color_type,
                    const std::vector<std::string>& rows, const std::string& plte = "",
                    const std::string& trns = "") {
  std::string raw;
  for (const std::string& r : rows) raw += '\0' + r;
  uLongf size = compressBound(raw.size());
  std::string z(size, '\0');
  compress(reinterpret_cast<Bytef*>(z.data()), &size, reinterpret_cast<const Bytef*>(raw.data()),
           raw.size());
  z.resize(size);
  std::string ihdr = Be32(width) + Be32(height);
  ihdr += {char(bit_depth), char(color_type), 0, 0, 0};
  std::string png("\x89PNG\r\n\x1a\n", 8);
  png += Chunk("IHDR", ihdr);
  if (!plte.empty()) png += Chunk("PLTE", plte);
  if (!trns.empty()) png += Chunk("tRNS", trns);
  return png + Chunk("IDAT", z) + Chunk("IEND", "");
}

std::string ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(ImageFilesTest, RealYcbvPngsDecodeToOpenCvsPixelsInEveryMode) {
  int images = 0;
  for (const char* folder : {"rgb", "depth"}) {
    const fs::path dir = fs::path(SKIMAP_YCBV_DIR) / "test" / "000000" / folder;
    ASSERT_TRUE(fs::is_directory(dir)) << dir;
    for (const auto& entry : fs::directory_iterator(dir)) {
      for (const ModePair& m : kModes) {
        absl::StatusOr<cv::Mat> ours = ReadImageFile(entry.path().string(), m.ours);
        ASSERT_TRUE(ours.ok()) << ours.status();
        EXPECT_TRUE(Same(*ours, cv::imread(entry.path().string(), m.opencv)))
            << entry.path() << " mode " << int(m.ours);
      }
      ++images;
    }
  }
  EXPECT_EQ(images, 20);
}

TEST(ImageFilesTest, PhotographJpegsDecodeToOpenCvsPixels) {
  int images = 0;
  for (const char* name :
       {"baboon.jpg", "fruits.jpg", "HappyFish.jpg", "left01.jpg", "building.jpg", "lena.jpg"}) {
    const std::string path = std::string(kDocData) + "/" + name;
    if (!fs::exists(path)) continue;
    for (const ModePair& m : kModes) {
      absl::StatusOr<cv::Mat> ours = ReadImageFile(path, m.ours);
      ASSERT_TRUE(ours.ok()) << ours.status();
      EXPECT_TRUE(Same(*ours, cv::imread(path, m.opencv))) << name << " mode " << int(m.ours);
    }
    ++images;
  }
  EXPECT_GE(images, 5);
}

TEST(ImageFilesTest, PngLayoutsOpenCvNeverWritesDecodeAsOpenCvDecodesThem) {
  std::vector<std::string> pngs;
  // Palette of three colours, the second half transparent.
  pngs.push_back(MakePng(4, 2, 8, 3, {{0, 1, 2, 1}, {2, 2, 0, 1}},
                         std::string("\xff\x00\x00\x00\xff\x00\x00\x00\xff", 9),
                         std::string("\xff\x80", 2)));
  // Grey + alpha, 8-bit.
  pngs.push_back(MakePng(3, 1, 8, 4, {std::string("\x10\xff\x80\x40\xf0\x00", 6)}));
  // 1-bit grey.
  pngs.push_back(MakePng(9, 2, 1, 0, {std::string("\xa5\x80", 2), std::string("\x0f\x00", 2)}));
  // 16-bit RGB and RGBA.
  pngs.push_back(
      MakePng(2, 1, 16, 2, {std::string("\x12\x34\xff\x00\x00\x01\xab\xcd\x00\x00\x80\x80", 12)}));
  pngs.push_back(MakePng(1, 1, 16, 6, {std::string("\x12\x34\xff\x00\x00\x01\x80\x00", 8)}));
  // 8-bit grey with a transparent grey level.
  pngs.push_back(
      MakePng(3, 1, 8, 0, {std::string("\x00\x7f\xff", 3)}, "", std::string("\x00\x7f", 2)));
  for (size_t i = 0; i < pngs.size(); ++i) {
    for (const ModePair& m : kModes) {
      const cv::Mat reference = OpenCvDecode(pngs[i], m.opencv);
      ASSERT_FALSE(reference.empty()) << i;
      absl::StatusOr<cv::Mat> ours = DecodeImage(pngs[i], m.ours);
      ASSERT_TRUE(ours.ok()) << ours.status() << " png " << i;
      EXPECT_TRUE(Same(*ours, reference)) << "png " << i << " mode " << int(m.ours) << "\nours "
                                          << *ours << "\nopencv " << reference;
    }
  }
}

TEST(ImageFilesTest, WhatWeEncodeOpenCvReadsBackExactly) {
  cv::RNG rng(3);
  for (int type : {CV_8UC1, CV_8UC3, CV_8UC4, CV_16UC1, CV_16UC3}) {
    cv::Mat image(37, 53, type);
    rng.fill(image, cv::RNG::UNIFORM, 0, type == CV_16UC1 || type == CV_16UC3 ? 65536 : 256);
    for (const char* ext : {".png", ".pgm", ".ppm"}) {
      const bool pnm_ok = (std::string(ext) == ".pgm" && image.channels() == 1) ||
                          (std::string(ext) == ".ppm" && type == CV_8UC3);
      if (std::string(ext) != ".png" && !pnm_ok) {
        EXPECT_FALSE(EncodeImage(ext, image).ok()) << ext << " type " << type;
        continue;
      }
      absl::StatusOr<std::string> bytes = EncodeImage(ext, image);
      ASSERT_TRUE(bytes.ok()) << bytes.status();
      EXPECT_TRUE(Same(OpenCvDecode(*bytes, cv::IMREAD_UNCHANGED), image)) << ext << " " << type;
      absl::StatusOr<cv::Mat> back = DecodeImage(*bytes, ImageMode::kUnchanged);
      ASSERT_TRUE(back.ok()) << back.status();
      EXPECT_TRUE(Same(*back, image)) << ext << " " << type;
    }
  }
  // JPEG: OpenCV decodes our bytes to what we decode them to, close to the original.
  const cv::Mat photo = cv::imread(std::string(kDocData) + "/baboon.jpg", cv::IMREAD_COLOR);
  ASSERT_FALSE(photo.empty());
  absl::StatusOr<std::string> jpeg = EncodeImage(".jpg", photo, {.jpeg_quality = 90});
  ASSERT_TRUE(jpeg.ok()) << jpeg.status();
  const cv::Mat reference = OpenCvDecode(*jpeg, cv::IMREAD_COLOR);
  EXPECT_TRUE(Same(DecodeImage(*jpeg, ImageMode::kColor).value_or(cv::Mat()), reference));
  EXPECT_LT(cv::norm(reference, photo, cv::NORM_L1) / photo.total() / 3, 8.0);
}

TEST(ImageFilesTest, TiffAndWebpFilesMatchOpenCv) {
  const fs::path dir = fs::temp_directory_path() / "skimap_image_files_test";
  fs::create_directories(dir);
  cv::Mat heights(20, 30, CV_32FC1);
  cv::randu(heights, -2.0f, 3.0f);
  heights.at<float>(3, 4) = std::numeric_limits<float>::quiet_NaN();
  const std::string ours_tiff = (dir / "ours.tiff").string();
  ASSERT_TRUE(WriteImageFile(ours_tiff, heights).ok());
  const cv::Mat opencv_read = cv::imread(ours_tiff, cv::IMREAD_UNCHANGED);
  ASSERT_EQ(opencv_read.type(), CV_32FC1);
  EXPECT_EQ(std::memcmp(opencv_read.data, heights.data, heights.total() * 4), 0);
  for (int type : {CV_32FC1, CV_16UC1, CV_8UC3}) {
    cv::Mat image(11, 17, type);
    cv::randu(image, 0, 200);
    const std::string theirs = (dir / "theirs.tif").string();
    ASSERT_TRUE(cv::imwrite(theirs, image));
    absl::StatusOr<cv::Mat> back = ReadImageFile(theirs, ImageMode::kUnchanged);
    ASSERT_TRUE(back.ok()) << back.status();
    EXPECT_TRUE(Same(*back, image)) << type;
  }
  std::vector<uint8_t> webp;
  const cv::Mat photo = cv::imread(std::string(kDocData) + "/fruits.jpg", cv::IMREAD_COLOR);
  ASSERT_TRUE(cv::imencode(".webp", photo, webp));
  const std::string bytes(webp.begin(), webp.end());
  for (const ModePair& m : {kModes[1], kModes[2]}) {
    absl::StatusOr<cv::Mat> ours = DecodeImage(bytes, m.ours);
    ASSERT_TRUE(ours.ok()) << ours.status();
    EXPECT_TRUE(Same(*ours, OpenCvDecode(bytes, m.opencv))) << int(m.ours);
  }
  fs::remove_all(dir);
}

TEST(ImageFilesTest, DecodesIntoTheCallersBufferWhenItFits) {
  cv::Mat grey(24, 32, CV_16UC1);
  cv::randu(grey, 0, 60000);
  const std::string png = EncodeImage(".png", grey).value();
  std::vector<uint16_t> buffer(24 * 32);
  cv::Mat target(24, 32, CV_16UC1, buffer.data());
  ASSERT_TRUE(DecodeImageInto(png, ImageMode::kAnyDepth, &target).ok());
  EXPECT_EQ(target.data, reinterpret_cast<uchar*>(buffer.data()));
  EXPECT_TRUE(Same(cv::Mat(24, 32, CV_16UC1, buffer.data()), grey));
}

TEST(ImageFilesTest, DamagedAndOversizedImagesAreRefusedByFormat) {
  const cv::Mat photo = cv::imread(std::string(kDocData) + "/baboon.jpg", cv::IMREAD_COLOR);
  const std::string png = EncodeImage(".png", photo).value();
  const std::string jpeg = EncodeImage(".jpg", photo).value();
  auto refused = [](const std::string& bytes, const std::string& name) {
    absl::StatusOr<cv::Mat> m = DecodeImage(bytes, ImageMode::kColor);
    EXPECT_EQ(m.status().code(), absl::StatusCode::kInvalidArgument) << name;
    EXPECT_NE(m.status().message().find(name), std::string::npos) << m.status();
  };
  refused(png.substr(0, png.size() / 2), "PNG");
  std::string bad_zlib = png;
  for (size_t i = 100; i < 400; ++i) bad_zlib[i] ^= 0x5a;
  refused(bad_zlib, "PNG");
  refused(std::string("garbage, not an image"), "not a PNG, JPEG, WebP");
  refused(jpeg.substr(0, 200), "JPEG");
  // A PNG claiming 100000 x 100000 pixels: refused from its header.
  refused(MakePng(100000, 100000, 8, 0, {std::string(4, '\0')}), "PNG");
  refused(std::string("P5\n100000 100000\n255\n") + std::string(16, '\0'), "PNM");
  refused(std::string("P5\n4 4\n255\n") + std::string(15, '\0'), "PNM");  // one sample short
  refused(std::string("P6\n-4 4\n255\n"), "PNM");
  EXPECT_EQ(ReadImageFile("/nonexistent/a.png", ImageMode::kColor).status().code(),
            absl::StatusCode::kNotFound);
  // A file over kMaxImageFileBytes is refused unread (sparse: no disk space taken). One at
  // the size of its contents reads as before.
  const fs::path dir = fs::temp_directory_path() / "skimap_image_files_size_test";
  fs::create_directories(dir);
  const std::string huge = (dir / "huge.png").string();
  std::ofstream(huge, std::ios::binary) << png;
  fs::resize_file(huge, kMaxImageFileBytes + 1);
  absl::StatusOr<cv::Mat> too_big = ReadImageFile(huge, ImageMode::kColor);
  EXPECT_EQ(too_big.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(too_big.status().message().find("huge.png"), std::string::npos) << too_big.status();
  EXPECT_NE(too_big.status().message().find("more than an image file may hold"), std::string::npos);
  fs::resize_file(huge, png.size());
  absl::StatusOr<cv::Mat> back = ReadImageFile(huge, ImageMode::kColor);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_TRUE(Same(*back, photo));
  fs::remove_all(dir);
  EXPECT_FALSE(EncodeImage(".bmp", photo).ok());
  EXPECT_FALSE(EncodeImage(".jpg", cv::Mat(4, 4, CV_16UC1)).ok());
}

// Filters `raw` scanlines (stride bytes each, bpp bytes per pixel) with PNG filter
// `types[r % types.size()]` per row, each prefixed by its type byte (PNG specification 9).
std::string FilterRows(const std::string& raw, size_t stride, size_t bpp,
                       const std::vector<int>& types) {
  std::string out;
  const size_t rows = raw.size() / stride;
  auto at = [&](size_t r, size_t i) -> int {  // 0 outside the image
    return r < rows ? static_cast<uint8_t>(raw[r * stride + i]) : 0;
  };
  for (size_t r = 0; r < rows; ++r) {
    const int type = types[r % types.size()];
    out += char(type);
    for (size_t i = 0; i < stride; ++i) {
      const int x = at(r, i), a = i >= bpp ? at(r, i - bpp) : 0, b = r > 0 ? at(r - 1, i) : 0,
                c = r > 0 && i >= bpp ? at(r - 1, i - bpp) : 0;
      int predictor = 0;
      if (type == 1) predictor = a;
      if (type == 2) predictor = b;
      if (type == 3) predictor = (a + b) / 2;
      if (type == 4) {
        const int pa = std::abs(b - c), pb = std::abs(a - c), pc = std::abs(a + b - 2 * c);
        predictor = pa <= pb && pa <= pc ? a : pb <= pc ? b : c;
      }
      out += char(static_cast<uint8_t>(x - predictor));
    }
  }
  return out;
}

// A PNG of already filtered scanlines, its IDAT split into chunks of `idat_size` bytes,
// with a tEXt chunk between IHDR and the first IDAT.
std::string MakeFilteredPng(int width, int height, int bit_depth, int color_type,
                            const std::string& filtered, size_t idat_size) {
  uLongf size = compressBound(filtered.size());
  std::string z(size, '\0');
  compress(reinterpret_cast<Bytef*>(z.data()), &size,
           reinterpret_cast<const Bytef*>(filtered.data()), filtered.size());
  z.resize(size);
  std::string ihdr = Be32(width) + Be32(height);
  ihdr += {char(bit_depth), char(color_type), 0, 0, 0};
  std::string png = std::string("\x89PNG\r\n\x1a\n", 8) + Chunk("IHDR", ihdr) +
                    Chunk("tEXt", std::string("Comment\0made by the test", 24));
  for (size_t at = 0; at < z.size(); at += idat_size) png += Chunk("IDAT", z.substr(at, idat_size));
  return png + Chunk("IEND", "");
}

TEST(ImageFilesTest, PngFastPathGivesLibpngsPixelsForEveryFilterLayoutAndMode) {
  using image_formats::DecodePngFast;
  using image_formats::DecodePngWithLibpng;
  struct Layout {
    int bit_depth, color_type, channels;
    bool fast;  // the fast path takes it (in the modes it handles)
  };
  const Layout layouts[] = {{8, 0, 1, true}, {16, 0, 1, true}, {8, 2, 3, true},
                            {8, 6, 4, true}, {8, 4, 2, false}, {16, 2, 3, false}};
  const std::vector<std::vector<int>> filters = {{0}, {1}, {2}, {3}, {4}, {4, 1, 0, 3, 2}};
  const ImageMode modes[] = {ImageMode::kUnchanged, ImageMode::kColor, ImageMode::kRgb,
                             ImageMode::kGrey, ImageMode::kAnyDepth};
  cv::RNG rng(11);
  int fast_decodes = 0;
  // Widths of one and two pixels take the byte-wise loops, 37 the vector ones (and their
  // last pixel); odd rows hold small values, so that Paeth's predictor often ties.
  for (const int width : {1, 2, 37})
    for (const Layout& l : layouts) {
      const int height = 6;
      const size_t bpp = size_t(l.channels) * l.bit_depth / 8, stride = bpp * width;
      std::string raw(stride * height, '\0');
      for (size_t i = 0; i < raw.size(); ++i) {
        raw[i] = char(i / stride % 2 == 0 ? rng.uniform(0, 256) : rng.uniform(0, 3));
      }
      for (const std::vector<int>& f : filters) {
        for (size_t idat_size : {size_t{7}, size_t{1} << 20}) {
          const std::string png = MakeFilteredPng(width, height, l.bit_depth, l.color_type,
                                                  FilterRows(raw, stride, bpp, f), idat_size);
          for (ImageMode mode : modes) {
            const std::string what = "width " + std::to_string(width) + " depth " +
                                     std::to_string(l.bit_depth) + " colour type " +
                                     std::to_string(l.color_type) + " filter " +
                                     std::to_string(f[0]) + " mode " + std::to_string(int(mode));
            cv::Mat reference, fast;
            ASSERT_TRUE(DecodePngWithLibpng(png, mode, &reference).ok()) << what;
            const bool handled = DecodePngFast(png, mode, &fast);
            const bool colour = l.color_type != 0;
            EXPECT_EQ(handled, l.fast && !(colour && (mode == ImageMode::kGrey ||
                                                      mode == ImageMode::kAnyDepth)))
                << what;
            if (!handled) continue;
            ++fast_decodes;
            EXPECT_TRUE(Same(fast, reference))
                << what << "\nfast " << fast << "\nlibpng " << reference;
          }
        }
      }
    }
  EXPECT_EQ(fast_decodes, 3 * 2 * 6 * (5 + 5 + 3 + 3));
  // The real ycbv PNGs (8-bit RGB, 16-bit depth) take the fast path.
  const fs::path dir = fs::path(SKIMAP_YCBV_DIR) / "test" / "000000";
  for (const char* file : {"rgb/000001.png", "depth/000001.png"}) {
    const std::string bytes = ReadFile((dir / file).string());
    cv::Mat fast, reference;
    const ImageMode mode = file[0] == 'r' ? ImageMode::kRgb : ImageMode::kAnyDepth;
    ASSERT_TRUE(DecodePngFast(bytes, mode, &fast)) << file;
    ASSERT_TRUE(DecodePngWithLibpng(bytes, mode, &reference).ok()) << file;
    EXPECT_TRUE(Same(fast, reference)) << file;
  }
}

TEST(ImageFilesTest, PngFastPathLeavesDamagedFilesToLibpng) {
  using image_formats::DecodePngFast;
  cv::Mat image(9, 13, CV_8UC3);
  cv::randu(image, 0, 256);
  const std::string png = EncodeImage(".png", image).value();
  const size_t idat = png.find("IDAT");
  ASSERT_NE(idat, std::string::npos);
  cv::Mat out;
  ASSERT_TRUE(DecodePngFast(png, ImageMode::kColor, &out));
  // A flipped bit in the IDAT data: its CRC no longer matches.
  std::string bad_crc = png;
  bad_crc[idat + 10] ^= 0x01;
  EXPECT_FALSE(DecodePngFast(bad_crc, ImageMode::kColor, &out));
  // Cut inside the IDAT; a filter type PNG does not define (5; its chunk's CRC matches).
  EXPECT_FALSE(DecodePngFast(png.substr(0, idat + 20), ImageMode::kColor, &out));
  std::string raw(13 * 3, '\x40');
  const std::string defined =
      MakeFilteredPng(13, 2, 8, 2, FilterRows(raw + raw, 39, 3, {4}), 1 << 20);
  EXPECT_TRUE(DecodePngFast(defined, ImageMode::kColor, &out));
  std::string undefined = MakeFilteredPng(
      13, 2, 8, 2, std::string(1, '\x05') + raw + std::string(1, '\0') + raw, 1 << 20);
  EXPECT_FALSE(DecodePngFast(undefined, ImageMode::kColor, &out));
  // Each refused by DecodeImage with libpng's own error, as before the fast path.
  for (const std::string& bytes : {bad_crc, undefined}) {
    absl::StatusOr<cv::Mat> m = DecodeImage(bytes, ImageMode::kColor);
    EXPECT_EQ(m.status().code(), absl::StatusCode::kInvalidArgument) << m.status();
    EXPECT_NE(m.status().message().find("PNG"), std::string::npos) << m.status();
  }
}

}  // namespace
}  // namespace skimap::perception
