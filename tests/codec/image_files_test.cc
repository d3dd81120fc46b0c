// Image files (codec/image_files.h) against OpenCV's imgcodecs, the decoder they replaced
// and the reference here (this is the one test program that links it): the real ycbv-0000
// PNGs and the opencv-doc JPEG photographs decode to exactly OpenCV's pixels in every
// mode; PNG layouts OpenCV's writer never makes (palette, transparency, grey + alpha, 1-bit,
// 16-bit colour) decode as OpenCV decodes them; what we encode OpenCV reads back exactly;
// and damaged or oversized images are refused by name, never a crash or a huge allocation.
#include "codec/image_files.h"

#include <gtest/gtest.h>
#include <zlib.h>

#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <string>
#include <vector>

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

}  // namespace
}  // namespace skimap::perception
