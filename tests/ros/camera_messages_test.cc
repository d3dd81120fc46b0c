// Camera messages as robots publish them, before they become frames: image_transport's
// compressedDepth (ros/bag/compressed_depth.h) decodes to the depth it was made from, and
// a camera_info with lens distortion is undone (ros/bag/rectify.h), on the real YCB-Video
// frames. Hostile messages are refused by topic and field.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>

#include "ros/bag/compressed_depth.h"
#include "ros/bag/rectify.h"
#include "ros/bag/ros_frames.h"
#include "tests/common/images.h"
#include "tests/ros/ros_test_data.h"

namespace skimap::testing {
namespace {

const std::vector<MmFrame>& Frames() {
  static const std::vector<MmFrame> frames = LoadMmFrames(SKIMAP_YCBV_DIR);
  return frames;
}

std::vector<uint16_t> Millimetres(const sensor_msgs::Image& image) {
  EXPECT_EQ(image.encoding, "16UC1");
  std::vector<uint16_t> out(size_t(image.width) * image.height);
  std::memcpy(out.data(), image.data.data(), out.size() * 2);
  return out;
}

TEST(CompressedDepthTest, PngAndRvlDecodeToTheDepthTheyHold) {
  ASSERT_FALSE(Frames().empty());
  const MmFrame& f = Frames()[0];
  for (const char* codec : {"png", "rvl"}) {
    const sensor_msgs::CompressedImage message = CompressedDepthMessage(f, codec);
    absl::StatusOr<sensor_msgs::Image> depth = bag::DecodeCompressedDepth(message, "/d");
    ASSERT_TRUE(depth.ok()) << codec << ": " << depth.status();
    EXPECT_EQ(depth->width, uint32_t(f.width));
    EXPECT_EQ(depth->height, uint32_t(f.height));
    EXPECT_EQ(depth->header.stamp, f.stamp);
    EXPECT_EQ(depth->header.frame_id, kOpticalFrame);
    EXPECT_EQ(Millimetres(*depth), f.depth_mm) << codec;
  }
  // Older writers: no codec named, or no suffix at all, mean PNG.
  for (const char* format : {"16UC1; compressedDepth", "16UC1"}) {
    sensor_msgs::CompressedImage message = CompressedDepthMessage(f, "png");
    message.format = format;
    absl::StatusOr<sensor_msgs::Image> depth = bag::DecodeCompressedDepth(message, "/d");
    ASSERT_TRUE(depth.ok()) << format << ": " << depth.status();
    EXPECT_EQ(Millimetres(*depth), f.depth_mm) << format;
  }
}

TEST(CompressedDepthTest, QuantisedInverseDepthDecodesWithinItsStep) {
  const MmFrame& f = Frames()[0];
  for (const char* codec : {"png", "rvl"}) {
    absl::StatusOr<sensor_msgs::Image> depth =
        bag::DecodeCompressedDepth(CompressedDepthMessage(f, codec, /*metres=*/true), "/d");
    ASSERT_TRUE(depth.ok()) << depth.status();
    const std::vector<uint16_t> mm = Millimetres(*depth);
    size_t measured = 0;
    for (size_t i = 0; i < mm.size(); ++i) {
      if (f.depth_mm[i] == 0) {
        EXPECT_EQ(mm[i], 0) << i;
        continue;
      }
      ++measured;
      // The quantisation step at depth d is d^2 / A (A = 10100): 0.2 mm at 1.5 m; truncation
      // and rounding to millimetres add up to 1 mm.
      const double d = f.depth_mm[i] / 1000.0;
      ASSERT_LE(std::abs(int(mm[i]) - int(f.depth_mm[i])), 1 + std::ceil(d * d / 10100 * 1000))
          << "pixel " << i;
    }
    EXPECT_GT(measured, mm.size() / 2);
  }
}

TEST(CompressedDepthTest, HostileMessagesAreRefusedByTopicAndField) {
  const MmFrame& f = Frames()[0];
  const sensor_msgs::CompressedImage good = CompressedDepthMessage(f, "png");
  const sensor_msgs::CompressedImage good_rvl = CompressedDepthMessage(f, "rvl");
  struct Case {
    const char* what;
    sensor_msgs::CompressedImage message;
    const char* expect;
  };
  std::vector<Case> cases;
  auto with = [](sensor_msgs::CompressedImage m, auto edit) {
    edit(m);
    return m;
  };
  cases.push_back({"another transport", with(good, [](auto& m) { m.format = "jpeg"; }),
                   "depth encoding \"jpeg\""});
  cases.push_back({"an unknown codec",
                   with(good, [](auto& m) { m.format = "16UC1; compressedDepth zip"; }),
                   "is not compressedDepth"});
  cases.push_back({"a colour encoding",
                   with(good, [](auto& m) { m.format = "rgb8; compressedDepth png"; }),
                   "depth encoding \"rgb8\""});
  cases.push_back({"no data", with(good, [](auto& m) { m.data.resize(12); }), "12-byte"});
  cases.push_back(
      {"another header format", with(good, [](auto& m) { m.data[0] = 7; }), "header format is 7"});
  cases.push_back({"non-finite quantisation",
                   with(CompressedDepthMessage(f, "png", true),
                        [](auto& m) { std::memset(m.data.data() + 4, 0xff, 4); }),
                   "not finite"});
  cases.push_back({"a truncated PNG", with(good, [](auto& m) { m.data.resize(m.data.size() / 2); }),
                   "/d: compressedDepth"});
  cases.push_back({"a PNG claiming 100000 x 100000",
                   with(good,
                        [](auto& m) {
                          // IHDR's width and height, big-endian, after the 8-byte signature
                          // and the chunk's length and type.
                          const uint8_t big[8] = {0, 1, 0x86, 0xa0, 0, 1, 0x86, 0xa0};
                          std::memcpy(m.data.data() + 12 + 16, big, 8);
                        }),
                   "outside 1..8192"});
  cases.push_back({"an 8-bit PNG",
                   with(good,
                        [&](auto& m) {
                          std::vector<uint8_t> png;
                          ImEncode(".png", cv::Mat(4, 4, CV_8UC1, 9), &png);
                          m.data.resize(12);
                          m.data.insert(m.data.end(), png.begin(), png.end());
                        }),
                   "/d: compressedDepth PNG"});
  cases.push_back({"RVL claiming 9000 columns",
                   with(good_rvl,
                        [](auto& m) {
                          const uint32_t w = 9000;
                          std::memcpy(m.data.data() + 12, &w, 4);
                        }),
                   "outside 1..8192"});
  cases.push_back({"RVL claiming more rows than it holds",
                   with(good_rvl,
                        [](auto& m) {
                          const uint32_t h = 4000;
                          std::memcpy(m.data.data() + 16, &h, 4);
                        }),
                   "/d: compressedDepth RVL"});
  cases.push_back({"RVL cut short",
                   with(good_rvl, [](auto& m) { m.data.resize(m.data.size() - 9); }),
                   "/d: compressedDepth RVL"});
  cases.push_back(
      {"RVL without its size", with(good_rvl, [](auto& m) { m.data.resize(16); }), "8-byte size"});
  for (const Case& c : cases) {
    absl::StatusOr<sensor_msgs::Image> depth = bag::DecodeCompressedDepth(c.message, "/d");
    ASSERT_FALSE(depth.ok()) << c.what;
    EXPECT_TRUE(absl::IsInvalidArgument(depth.status())) << c.what << ": " << depth.status();
    EXPECT_NE(depth.status().message().find(c.expect), std::string::npos)
        << c.what << ": " << depth.status();
    EXPECT_EQ(depth.status().message().rfind("/d", 0), 0u) << c.what << ": " << depth.status();
  }
}

TEST(CompressedDepthTest, AnImageOfAnotherSizeThanCameraInfoIsRefusedBeforeDecoding) {
  const MmFrame& f = Frames()[0];
  for (const char* codec : {"png", "rvl"}) {
    absl::StatusOr<sensor_msgs::Image> depth = bag::DecodeCompressedDepth(
        CompressedDepthMessage(f, codec), "/d", f.width / 2, f.height / 2);
    ASSERT_FALSE(depth.ok()) << codec;
    EXPECT_NE(depth.status().message().find("camera_info is for 320x240"), std::string::npos)
        << depth.status();
    EXPECT_TRUE(
        bag::DecodeCompressedDepth(CompressedDepthMessage(f, codec), "/d", f.width, f.height).ok());
  }
}

// The frame ros_frames.h makes of `f`'s messages, with `info`.
bag::RosFrame MakeFrame(const MmFrame& f, const sensor_msgs::CameraInfo& info, bool jpeg = false) {
  const sensor_msgs::Image depth = DepthMessage(f), color = ColorMessage(f);
  sensor_msgs::CompressedImage compressed;
  bag::ColorMessage c;
  c.topic = "/c";
  if (jpeg) {
    compressed.format = "rgb8; jpeg compressed bgr8";
    cv::Mat rgb(f.height, f.width, CV_8UC3, const_cast<uint8_t*>(f.rgb.data())), bgr;
    cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
    ImEncode(".jpg", bgr, &compressed.data);
    c.compressed = &compressed;
  } else {
    c.image = &color;
  }
  absl::StatusOr<bag::RosFrame> frame =
      bag::MakeRosFrame(depth, "/d", c, info, "/i", Eigen::Isometry3d::Identity());
  EXPECT_TRUE(frame.ok()) << frame.status();
  return frame.ok() ? *std::move(frame) : bag::RosFrame();
}

// Of the pixels with depth in `truth` (inside a margin of the border, where a distorted
// image still sees), the fraction `depth` gives within `tolerance` mm.
double Agreement(const std::vector<uint16_t>& depth, const MmFrame& truth, int tolerance) {
  size_t measured = 0, same = 0;
  const int margin = 40;
  for (int y = margin; y < truth.height - margin; ++y) {
    for (int x = margin; x < truth.width - margin; ++x) {
      const size_t i = size_t(y) * truth.width + x;
      if (truth.depth_mm[i] == 0) continue;
      ++measured;
      if (std::abs(int(depth[i]) - int(truth.depth_mm[i])) <= tolerance) ++same;
    }
  }
  return measured == 0 ? 0 : double(same) / measured;
}

// Of the pixels of a frame whose depth says where each pinhole pixel is (1000 + 2 x mm,
// or 1000 + 2 y mm with `rows`), the fraction that, after the round trip through the lens
// (model, D) and back, hold their own column's (row's) depth, to the pixel; and the same
// for the distorted image taken as pinhole.
std::pair<double, double> OwnRayFractions(const std::string& model, const std::vector<double>& D,
                                          bool rows) {
  MmFrame truth = Frames()[0];
  for (int y = 0; y < truth.height; ++y) {
    for (int x = 0; x < truth.width; ++x) {
      truth.depth_mm[size_t(y) * truth.width + x] = uint16_t(1000 + 2 * (rows ? y : x));
    }
  }
  const MmFrame distorted = Distorted(truth, D, model == "equidistant");
  sensor_msgs::CameraInfo info = InfoMessage(distorted);
  info.distortion_model = model;
  info.D = D;
  bag::Rectifier rectifier;
  bag::RosFrame frame = MakeFrame(distorted, info);
  EXPECT_TRUE(rectifier.Rectify(info, "/i", "/c", &frame).ok());
  EXPECT_EQ(frame.frame.intrinsics().fx(), truth.fx);  // the camera matrix stays K
  return {Agreement(frame.depth_mm, truth, 2), Agreement(distorted.depth_mm, truth, 2)};
}

TEST(RectifierTest, EveryPixelLandsOnItsOwnRay) {
  for (bool rows : {false, true}) {
    const auto [rectified, as_sent] = OwnRayFractions("plumb_bob", LensDistortion(), rows);
    std::printf("%s within a pixel: rectified %.3f, distorted taken as pinhole %.3f\n",
                rows ? "rows" : "columns", rectified, as_sent);
    EXPECT_GT(rectified, 0.99);  // 1.000 (2026-11-29)
    EXPECT_LT(as_sent, 0.8);     // 0.563 columns: most pixels moved by more than one
  }
}

TEST(RectifierTest, TheFisheyeModelIsUndoneToo) {
  const std::vector<double> D = {0.05, -0.02, 0.004, 0};
  for (bool rows : {false, true}) {
    const auto [rectified, as_sent] = OwnRayFractions("equidistant", D, rows);
    std::printf("equidistant, %s within a pixel: rectified %.3f, taken as pinhole %.3f\n",
                rows ? "rows" : "columns", rectified, as_sent);
    EXPECT_GT(rectified, 0.99);
    EXPECT_LT(as_sent, 0.8);
  }
}

TEST(RectifierTest, DistortionIsUndoneOnDepthAndColour) {
  const MmFrame& truth = Frames()[0];
  const MmFrame distorted = Distorted(truth);
  sensor_msgs::CameraInfo info = InfoMessage(distorted);
  info.D = LensDistortion();
  bag::Rectifier rectifier;
  bag::RosFrame frame = MakeFrame(distorted, info);
  ASSERT_TRUE(rectifier.Rectify(info, "/i", "/c", &frame).ok());
  const double rectified = Agreement(frame.depth_mm, truth, 10);
  std::printf("real depth within 1 cm: rectified %.3f, distorted taken as pinhole %.3f\n",
              rectified, Agreement(distorted.depth_mm, truth, 10));
  EXPECT_GT(rectified, 0.95);  // 0.986 (2026-11-29): depth resampled twice to the nearest pixel
  // Colour moved with it: mean absolute difference to the truth's colour, per channel.
  ASSERT_EQ(frame.frame.color_encoding(), v1::COLOR_ENCODING_RAW_RGB8);
  const std::string& rgb = frame.frame.color();
  ASSERT_EQ(rgb.size(), truth.rgb.size());
  auto colour_error = [&](const uint8_t* image) {
    double sum = 0;
    size_t n = 0;
    for (int y = 60; y < truth.height - 60; ++y) {
      for (int x = 60; x < truth.width - 60; ++x) {
        for (int k = 0; k < 3; ++k, ++n) {
          const size_t i = (size_t(y) * truth.width + x) * 3 + k;
          sum += std::abs(int(image[i]) - int(truth.rgb[i]));
        }
      }
    }
    return sum / n;
  };
  const double colour_rectified = colour_error(reinterpret_cast<const uint8_t*>(rgb.data()));
  const double colour_as_sent = colour_error(distorted.rgb.data());
  std::printf("colour, mean absolute error: rectified %.2f, distorted taken as pinhole %.2f\n",
              colour_rectified, colour_as_sent);
  EXPECT_LT(colour_rectified, colour_as_sent / 2);  // 5.2 against 16.0 (2026-11-29)
}

TEST(RectifierTest, CompressedColourIsDecodedAndSentRaw) {
  const MmFrame distorted = Distorted(Frames()[0]);
  sensor_msgs::CameraInfo info = InfoMessage(distorted);
  info.D = LensDistortion();
  bag::Rectifier rectifier;
  bag::RosFrame frame = MakeFrame(distorted, info, /*jpeg=*/true);
  ASSERT_EQ(frame.frame.color_encoding(), v1::COLOR_ENCODING_JPEG);
  ASSERT_TRUE(rectifier.Rectify(info, "/i", "/c", &frame).ok());
  EXPECT_EQ(frame.frame.color_encoding(), v1::COLOR_ENCODING_RAW_RGB8);
  EXPECT_EQ(frame.frame.color().size(), size_t(distorted.width) * distorted.height * 3);
}

TEST(RectifierTest, RectifiedImagesAreLeftAsTheyAre) {
  const MmFrame& f = Frames()[0];
  sensor_msgs::CameraInfo info = InfoMessage(f);  // plumb_bob, D all zero
  bag::Rectifier rectifier;
  bag::RosFrame frame = MakeFrame(f, info);
  const bag::RosFrame before = frame;
  ASSERT_TRUE(rectifier.Rectify(info, "/i", "/c", &frame).ok());
  EXPECT_EQ(frame.depth_mm, before.depth_mm);
  EXPECT_EQ(frame.frame.color(), before.frame.color());
  // A driver that leaves the model empty with no coefficients: rectified too.
  info.distortion_model = "";
  info.D.clear();
  ASSERT_TRUE(rectifier.Rectify(info, "/i", "/c", &frame).ok());
  EXPECT_EQ(frame.depth_mm, before.depth_mm);
}

TEST(RectifierTest, AnUnusableDistortionIsRefusedByField) {
  const MmFrame& f = Frames()[0];
  bag::Rectifier rectifier;
  struct Case {
    std::string model;
    std::vector<double> D;
    const char* expect;
  };
  const std::vector<Case> cases = {
      {"kannala_brandt_8", {0.1, 0.2, 0, 0}, "distortion_model \"kannala_brandt_8\""},
      {"plumb_bob", {0.1, 0.2, 0}, "D has 3 coefficients"},
      {"equidistant", {0.1, 0.2, 0, 0, 0}, "D has 5 coefficients"},
      {"plumb_bob", {0.1, std::nan(""), 0, 0, 0}, "D[1]"},
  };
  {
    // A frame of another size than its camera_info (a caller's mistake): refused, not read.
    sensor_msgs::CameraInfo info = InfoMessage(f);
    info.D = LensDistortion();
    bag::RosFrame frame = MakeFrame(f, info);
    info.width /= 2;
    const absl::Status s = rectifier.Rectify(info, "/i", "/c", &frame);
    EXPECT_TRUE(absl::IsInvalidArgument(s)) << s;
  }
  for (const Case& c : cases) {
    sensor_msgs::CameraInfo info = InfoMessage(f);
    info.distortion_model = c.model;
    info.D = c.D;
    bag::RosFrame frame = MakeFrame(f, info);
    const absl::Status s = rectifier.Rectify(info, "/i", "/c", &frame);
    EXPECT_TRUE(absl::IsInvalidArgument(s)) << c.expect << ": " << s;
    EXPECT_NE(s.message().find(c.expect), std::string::npos) << s;
    EXPECT_EQ(s.message().rfind("/i: ", 0), 0u) << s;
  }
}

}  // namespace
}  // namespace skimap::testing
