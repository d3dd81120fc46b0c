// SetFrameDepth (client/frame_depth.h): the client library's depth encodings, zstd by
// default, decode in the server (server::DecodeFrame) to exactly the pixels sent, on a
// real ycbv depth image and on odd sizes; bad sizes and encodings are refused by name.
#include "client/frame_depth.h"

#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "server/core/maps/frame_decode.h"
#include "tests/common/images.h"

namespace skimap::client {
namespace {

v1::Frame Header(int width, int height) {
  v1::Frame f;
  v1::CameraIntrinsics* k = f.mutable_intrinsics();
  // A 60-degree field of view whatever the size (the server checks it).
  k->set_fx(0.87 * width), k->set_fy(0.87 * height);
  k->set_cx(width / 2.0), k->set_cy(height / 2.0);
  k->set_width(width), k->set_height(height);
  f.mutable_pose()->mutable_rotation()->set_w(1);
  f.set_depth_scale(0.001);
  return f;
}

// Encodes with `encoding` (the default when unspecified) and decodes in the server.
std::vector<uint16_t> RoundTrip(const std::vector<uint16_t>& pixels, int width, int height,
                                v1::DepthEncoding encoding, v1::DepthEncoding* sent) {
  v1::Frame f = Header(width, height);
  const absl::Status s = encoding == v1::DEPTH_ENCODING_UNSPECIFIED
                             ? SetFrameDepth(pixels.data(), width, height, &f)
                             : SetFrameDepth(pixels.data(), width, height, &f, encoding);
  EXPECT_TRUE(s.ok()) << s;
  *sent = f.depth_encoding();
  absl::StatusOr<perception::RgbdFrame> decoded = server::DecodeFrame(f);
  EXPECT_TRUE(decoded.ok()) << decoded.status();
  return decoded.ok() ? decoded->depth.pixels : std::vector<uint16_t>();
}

constexpr v1::DepthEncoding kAll[] = {v1::DEPTH_ENCODING_ZSTD, v1::DEPTH_ENCODING_RVL,
                                      v1::DEPTH_ENCODING_PNG16, v1::DEPTH_ENCODING_RAW_U16};

TEST(FrameDepthTest, TheDefaultIsZstd) {
  EXPECT_EQ(kDefaultDepthEncoding, v1::DEPTH_ENCODING_ZSTD);
  const std::vector<uint16_t> pixels(12, 1000);
  v1::DepthEncoding sent;
  EXPECT_EQ(RoundTrip(pixels, 4, 3, v1::DEPTH_ENCODING_UNSPECIFIED, &sent), pixels);
  EXPECT_EQ(sent, v1::DEPTH_ENCODING_ZSTD);
}

TEST(FrameDepthTest, RealSensorDepthDecodesExactlyInEveryEncoding) {
  const cv::Mat png = skimap::testing::ImRead(SKIMAP_YCBV_DIR "/test/000000/depth/000000.png",
                                              skimap::testing::ImageMode::kAnyDepth);
  ASSERT_EQ(png.type(), CV_16UC1);
  const std::vector<uint16_t> pixels(png.begin<uint16_t>(), png.end<uint16_t>());
  size_t zeros = 0;
  for (const uint16_t p : pixels) zeros += p == 0;
  ASSERT_GT(zeros, 0u);  // holes, as a real sensor's depth has
  for (const v1::DepthEncoding e : kAll) {
    v1::DepthEncoding sent;
    EXPECT_EQ(RoundTrip(pixels, png.cols, png.rows, e, &sent), pixels) << v1::DepthEncoding_Name(e);
    EXPECT_EQ(sent, e);
  }
}

TEST(FrameDepthTest, OddSizesAndExtremeValuesDecodeExactly) {
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> value(0, 65535);
  for (const auto [w, h] : {std::pair{1, 1}, {3, 7}, {641, 3}, {13, 480}}) {
    std::vector<uint16_t> pixels(size_t(w) * h);
    for (uint16_t& p : pixels) p = static_cast<uint16_t>(value(rng));
    pixels[0] = 65535;
    for (const v1::DepthEncoding e : kAll) {
      v1::DepthEncoding sent;
      EXPECT_EQ(RoundTrip(pixels, w, h, e, &sent), pixels)
          << v1::DepthEncoding_Name(e) << " " << w << "x" << h;
    }
  }
}

TEST(FrameDepthTest, BadSizesAndEncodingsAreRefusedByName) {
  const std::vector<uint16_t> pixels(16, 1);
  v1::Frame f;
  absl::Status s = SetFrameDepth(pixels.data(), 0, 4, &f);
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("depth"), std::string::npos) << s;
  s = SetFrameDepth(pixels.data(), 4, 4, &f, v1::DEPTH_ENCODING_UNSPECIFIED);
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("depth_encoding"), std::string::npos) << s;
  EXPECT_TRUE(f.depth().empty());  // unchanged on error
}

}  // namespace
}  // namespace skimap::client
