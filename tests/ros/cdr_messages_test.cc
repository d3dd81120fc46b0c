// DecodeCdr on messages built here byte by byte, in both byte orders (the npm writer of
// tests/ros/mcap_writer writes little endian only; mcap_reader_test decodes its messages),
// then every prefix of each, and absurd counts.
#include "ros/bag/cdr_messages.h"

#include <gtest/gtest.h>

#include <cstring>
#include <string>
#include <vector>

namespace skimap::bag {
namespace {

// Writes XCDR1 with an encapsulation header, aligned relative to the byte after it.
class CdrBuilder {
 public:
  explicit CdrBuilder(bool big_endian) : big_endian_(big_endian) {
    out_ = std::string("\x00", 1) + (big_endian ? '\x00' : '\x01') + std::string(2, '\0');
  }
  CdrBuilder& U8(uint8_t v) { return Raw(&v, 1); }
  CdrBuilder& U32(uint32_t v) { return Raw(&v, 4); }
  CdrBuilder& I32(int32_t v) { return Raw(&v, 4); }
  CdrBuilder& F64(double v) { return Raw(&v, 8); }
  CdrBuilder& String(const std::string& s) {
    U32(static_cast<uint32_t>(s.size() + 1));
    out_ += s;
    out_.push_back('\0');
    return *this;
  }
  CdrBuilder& Bytes(const std::string& b) {
    U32(static_cast<uint32_t>(b.size()));
    out_ += b;
    return *this;
  }
  CdrBuilder& Header(int32_t sec, uint32_t nanosec, const std::string& frame) {
    return I32(sec).U32(nanosec).String(frame);
  }
  const std::string& str() const { return out_; }

 private:
  CdrBuilder& Raw(const void* v, size_t n) {
    while ((out_.size() - 4) % n != 0) out_.push_back('\x55');  // padding: any value
    char b[8];
    std::memcpy(b, v, n);
    if (big_endian_) std::reverse(b, b + n);
    out_.append(b, n);
    return *this;
  }
  bool big_endian_;
  std::string out_;
};

std::string ImageCdr(bool big_endian) {
  return CdrBuilder(big_endian)
      .Header(1000, 33333333, "camera_color_optical_frame")
      .U32(2)
      .U32(3)
      .String("16UC1")
      .U8(0)
      .U32(6)
      .Bytes(std::string("\x01\x02\x03\x04\x05\x06\x07\x08\x09\x0a\x0b\x0c", 12))
      .str();
}

std::string CompressedCdr(bool big_endian) {
  return CdrBuilder(big_endian).Header(7, 8, "cam").String("png").Bytes("\x89PNG").str();
}

std::string CameraInfoCdr(bool big_endian) {
  CdrBuilder b(big_endian);
  b.Header(5, 6, "optical").U32(480).U32(640).String("plumb_bob").U32(5);
  for (int i = 0; i < 5; ++i) b.F64(0.1 * i);
  for (int i = 0; i < 9 + 9 + 12; ++i) b.F64(i + 0.5);  // k, r, p
  b.U32(1).U32(2).U32(3).U32(4).U32(5).U32(6).U8(1);    // binning, roi
  return b.str();
}

std::string TfCdr(bool big_endian) {
  CdrBuilder b(big_endian);
  b.U32(2);
  for (int i = 0; i < 2; ++i) {
    b.Header(10 + i, 20, "world").String(i == 0 ? "camera_link" : "x");
    for (int j = 0; j < 7; ++j) b.F64(i * 10 + j + 0.25);
  }
  return b.str();
}

class CdrMessagesTest : public ::testing::TestWithParam<bool> {};

TEST_P(CdrMessagesTest, DecodesImage) {
  sensor_msgs::Image m;
  ASSERT_TRUE(DecodeCdr(ImageCdr(GetParam()), &m).ok());
  EXPECT_EQ(m.header.stamp.sec, 1000u);
  EXPECT_EQ(m.header.stamp.nsec, 33333333u);
  EXPECT_EQ(m.header.frame_id, "camera_color_optical_frame");
  EXPECT_EQ(m.height, 2u);
  EXPECT_EQ(m.width, 3u);
  EXPECT_EQ(m.encoding, "16UC1");
  EXPECT_EQ(m.step, 6u);
  EXPECT_EQ(m.data.size(), 12u);
  EXPECT_EQ(m.data[11], 0x0c);
}

TEST_P(CdrMessagesTest, DecodesCompressedImage) {
  sensor_msgs::CompressedImage m;
  ASSERT_TRUE(DecodeCdr(CompressedCdr(GetParam()), &m).ok());
  EXPECT_EQ(m.header.stamp.sec, 7u);
  EXPECT_EQ(m.format, "png");
  EXPECT_EQ(std::string(m.data.begin(), m.data.end()), "\x89PNG");
}

TEST_P(CdrMessagesTest, DecodesCameraInfoIntoRos1Names) {
  sensor_msgs::CameraInfo m;
  ASSERT_TRUE(DecodeCdr(CameraInfoCdr(GetParam()), &m).ok());
  EXPECT_EQ(m.header.frame_id, "optical");
  EXPECT_EQ(m.height, 480u);
  EXPECT_EQ(m.width, 640u);
  EXPECT_EQ(m.distortion_model, "plumb_bob");
  ASSERT_EQ(m.D.size(), 5u);
  EXPECT_EQ(m.D[4], 0.1 * 4);
  EXPECT_EQ(m.K[0], 0.5);
  EXPECT_EQ(m.K[8], 8.5);
  EXPECT_EQ(m.R[0], 9.5);
  EXPECT_EQ(m.P[11], 29.5);
  EXPECT_EQ(m.binning_x, 1u);
  EXPECT_EQ(m.binning_y, 2u);
  EXPECT_EQ(m.roi.x_offset, 3u);
  EXPECT_EQ(m.roi.width, 6u);
  EXPECT_EQ(m.roi.do_rectify, 1);
}

TEST_P(CdrMessagesTest, DecodesTfMessage) {
  tf2_msgs::TFMessage m;
  ASSERT_TRUE(DecodeCdr(TfCdr(GetParam()), &m).ok());
  ASSERT_EQ(m.transforms.size(), 2u);
  EXPECT_EQ(m.transforms[0].child_frame_id, "camera_link");
  EXPECT_EQ(m.transforms[1].header.stamp.sec, 11u);
  EXPECT_EQ(m.transforms[1].child_frame_id, "x");
  EXPECT_EQ(m.transforms[1].transform.translation.x, 10.25);
  EXPECT_EQ(m.transforms[1].transform.rotation.w, 16.25);
}

// Every proper prefix is InvalidArgument naming the type and a field (or the header).
template <typename Msg>
void EveryPrefixIsRejected(const std::string& cdr, const std::string& type) {
  Msg m;
  ASSERT_TRUE(DecodeCdr(cdr, &m).ok()) << type;
  for (size_t n = 0; n < cdr.size(); ++n) {
    Msg cut;
    const absl::Status s = DecodeCdr(std::string_view(cdr).substr(0, n), &cut);
    ASSERT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << type << " " << n;
    const std::string text(s.message());
    EXPECT_EQ(text.rfind(type, 0), 0u) << text;
    if (n >= 4) {
      EXPECT_EQ(text.substr(type.size(), 1), ".") << text;  // "<type>.<field>: ..."
    } else {
      EXPECT_NE(text.find("encapsulation"), std::string::npos) << text;
    }
  }
}

TEST_P(CdrMessagesTest, EveryPrefixIsRejectedNamingAField) {
  EveryPrefixIsRejected<sensor_msgs::Image>(ImageCdr(GetParam()), "sensor_msgs/msg/Image");
  EveryPrefixIsRejected<sensor_msgs::CompressedImage>(CompressedCdr(GetParam()),
                                                      "sensor_msgs/msg/CompressedImage");
  EveryPrefixIsRejected<sensor_msgs::CameraInfo>(CameraInfoCdr(GetParam()),
                                                 "sensor_msgs/msg/CameraInfo");
  EveryPrefixIsRejected<tf2_msgs::TFMessage>(TfCdr(GetParam()), "tf2_msgs/msg/TFMessage");
}

INSTANTIATE_TEST_SUITE_P(ByteOrders, CdrMessagesTest, ::testing::Values(false, true),
                         [](const auto& info) {
                           return info.param ? "BigEndian" : "LittleEndian";
                         });

TEST(CdrMessagesLimitsTest, AbsurdCountsAreRefusedBeforeAllocating) {
  sensor_msgs::Image image;
  const std::string big = CdrBuilder(false)
                              .Header(1, 2, "f")
                              .U32(480)
                              .U32(640)
                              .String("rgb8")
                              .U8(0)
                              .U32(1920)
                              .U32(921600)
                              .U32(0)  // 4 bytes of data
                              .str();
  EXPECT_EQ(DecodeCdr(big, &image),
            absl::InvalidArgumentError(
                "sensor_msgs/msg/Image.data: 921600 bytes declared, 4 bytes left"));

  tf2_msgs::TFMessage tf;
  const absl::Status s = DecodeCdr(CdrBuilder(false).U32(0xFFFFFFFF).str(), &tf);
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("tf2_msgs/msg/TFMessage.transforms: 4294967295 elements"),
            std::string::npos)
      << s;

  sensor_msgs::CameraInfo info;
  const std::string d =
      CdrBuilder(false).Header(1, 2, "f").U32(1).U32(1).String("x").U32(1u << 30).str();
  EXPECT_NE(DecodeCdr(d, &info).message().find("sensor_msgs/msg/CameraInfo.d: 1073741824"),
            std::string::npos);
}

TEST(CdrMessagesLimitsTest, RefusesOtherEncapsulationsAndBadStamps) {
  sensor_msgs::CompressedImage m;
  std::string pl_cdr = CompressedCdr(false);
  pl_cdr[1] = 0x03;  // PL_CDR_LE
  EXPECT_NE(DecodeCdr(pl_cdr, &m).message().find("encapsulation 0x0003"), std::string::npos);
  EXPECT_EQ(DecodeCdr(CdrBuilder(false).Header(-1, 0, "f").String("").Bytes("").str(), &m),
            absl::InvalidArgumentError(
                "sensor_msgs/msg/CompressedImage.header.stamp.sec: -1 is negative"));
  EXPECT_FALSE(
      DecodeCdr(CdrBuilder(false).Header(0, 1000000000, "f").String("").Bytes("").str(), &m).ok());
}

TEST(CdrMessagesLimitsTest, AcceptsAZeroLengthString) {
  sensor_msgs::CompressedImage m;
  m.format = "stale";
  ASSERT_TRUE(DecodeCdr(CdrBuilder(false).Header(0, 0, "f").U32(0).Bytes("x").str(), &m).ok());
  EXPECT_EQ(m.format, "");
  EXPECT_EQ(m.data.size(), 1u);
}

}  // namespace
}  // namespace skimap::bag
