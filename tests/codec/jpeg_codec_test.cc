// JPEG colour decoding (codec/image_codec.h, libjpeg-turbo's TurboJPEG API): on the
// real ycbv-0000 colour images it gives exactly the pixels of OpenCV's decoder (the
// reference it replaced), greyscale JPEGs come out as RGB, and damaged images are refused
// with an error naming `color` (or decode as libjpeg recovers them), never a crash.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "codec/image_codec.h"

namespace skimap::perception {
namespace {

std::string ReadFile(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream bytes;
  bytes << in.rdbuf();
  return bytes.str();
}

std::vector<uint8_t> OpenCvRgb(const std::string& jpeg) {
  const cv::Mat wrapped(1, static_cast<int>(jpeg.size()), CV_8UC1, const_cast<char*>(jpeg.data()));
  cv::Mat bgr = cv::imdecode(wrapped, cv::IMREAD_COLOR), rgb;
  cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  return std::vector<uint8_t>(rgb.data, rgb.data + rgb.total() * 3);
}

TEST(JpegCodecTest, RealYcbvColourDecodesToExactlyOpenCvsPixels) {
  const std::filesystem::path dir =
      std::filesystem::path(SKIMAP_YCBV_DIR) / "test" / "000000" / "rgb";
  ASSERT_TRUE(std::filesystem::is_directory(dir)) << dir;
  int images = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    absl::StatusOr<ColorImage> png =
        DecodeColor(ColorCodec::kPng, ReadFile(entry.path()), 640, 480);
    ASSERT_TRUE(png.ok()) << png.status();
    const absl::StatusOr<std::string> jpeg = EncodeColor(ColorCodec::kJpeg, *png);
    ASSERT_TRUE(jpeg.ok()) << jpeg.status();
    absl::StatusOr<ColorImage> ours = DecodeColor(ColorCodec::kJpeg, *jpeg, 640, 480);
    ASSERT_TRUE(ours.ok()) << ours.status();
    EXPECT_EQ(ours->rgb, OpenCvRgb(*jpeg)) << entry.path();
    // And close to the original: q90 on this noisy sensor image measured 6.4-6.5 levels of
    // mean absolute error; 8 leaves a margin.
    double error = 0;
    for (size_t i = 0; i < png->rgb.size(); ++i) error += std::abs(png->rgb[i] - ours->rgb[i]);
    EXPECT_LT(error / double(png->rgb.size()), 8.0) << entry.path();
    ++images;
  }
  EXPECT_EQ(images, 10);
}

TEST(JpegCodecTest, GreyscaleJpegDecodesToEqualChannels) {
  cv::Mat grey(48, 64, CV_8UC1);
  for (int r = 0; r < grey.rows; ++r) {
    for (int c = 0; c < grey.cols; ++c) grey.at<uint8_t>(r, c) = static_cast<uint8_t>(4 * c);
  }
  std::vector<uint8_t> buf;
  ASSERT_TRUE(cv::imencode(".jpg", grey, buf));
  absl::StatusOr<ColorImage> rgb =
      DecodeColor(ColorCodec::kJpeg, std::string(buf.begin(), buf.end()), 64, 48);
  ASSERT_TRUE(rgb.ok()) << rgb.status();
  for (size_t i = 0; i < rgb->rgb.size(); i += 3) {
    ASSERT_EQ(rgb->rgb[i], rgb->rgb[i + 1]);
    ASSERT_EQ(rgb->rgb[i], rgb->rgb[i + 2]);
  }
  EXPECT_NEAR(rgb->rgb[3 * 40], 160, 4);  // column 40 of row 0
}

TEST(JpegCodecTest, DamagedJpegsAreRefusedNamingColourOrRecovered) {
  ColorImage image{.width = 64, .height = 48, .rgb = std::vector<uint8_t>(64 * 48 * 3)};
  for (size_t i = 0; i < image.rgb.size(); ++i) image.rgb[i] = static_cast<uint8_t>(i * 7);
  const std::string jpeg = *EncodeColor(ColorCodec::kJpeg, image);
  // Cut short: no end-of-image marker, refused before decoding.
  absl::StatusOr<ColorImage> cut =
      DecodeColor(ColorCodec::kJpeg, jpeg.substr(0, jpeg.size() / 2), 64, 48);
  EXPECT_EQ(cut.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(cut.status().message().find("color"), std::string::npos) << cut.status();
  // Every byte of the entropy-coded data flipped in turn (a sample of them): each image is
  // either refused with a message naming `color` or decoded in full.
  for (size_t at = jpeg.size() / 2; at + 2 < jpeg.size(); at += 17) {
    std::string bad = jpeg;
    bad[at] = static_cast<char>(bad[at] ^ 0x5a);
    absl::StatusOr<ColorImage> out = DecodeColor(ColorCodec::kJpeg, bad, 64, 48);
    if (out.ok()) {
      EXPECT_EQ(out->rgb.size(), image.rgb.size());
    } else {
      EXPECT_EQ(out.status().code(), absl::StatusCode::kInvalidArgument);
      EXPECT_EQ(out.status().message().rfind("color", 0), 0u) << out.status();
    }
  }
  // A header that claims another size is refused before decoding.
  EXPECT_EQ(DecodeColor(ColorCodec::kJpeg, jpeg, 32, 48).status().code(),
            absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace skimap::perception
