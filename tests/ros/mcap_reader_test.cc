// McapReader against bags written by an independent writer (tests/ros/mcap_writer, npm's
// @mcap/core and @foxglove/rosmsg2-serialization) from the ycbv scene: every compression,
// chunked and unchunked, decoded back to the source PNGs' pixels, the tf tree composed
// back to the BOP poses; then the same bags damaged byte by byte.
#include "ros/bag/mcap_reader.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "ros/bag/cdr_messages.h"
#include "tests/common/images.h"

namespace skimap::bag {
namespace {

const std::string kScene = SKIMAP_YCBV_SCENE;
const std::string kWriter = "tests/ros/mcap_writer/write_bag.mjs";  // from the source dir

std::string ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// The bags a test wrote, removed by the fixture's TearDown.
std::vector<std::string>& Written() {
  static std::vector<std::string> files;
  return files;
}

// Runs the writer with `flags` into a fresh file; returns its path. Fails the test when the
// writer fails (its packages missing, say).
std::string WriteBag(const std::string& flags) {
  const std::string node = SKIMAP_NODE;  // the fixture skips when there is none
  static int count = 0;
  const std::string out = ::testing::TempDir() + "mcap_reader_test_" + std::to_string(getpid()) +
                          "_" + std::to_string(count++) + ".mcap";
  const std::string cmd =
      node + " " + kWriter + " " + kScene + " " + out + " " + flags + " 2>" + out + ".err";
  Written().push_back(out);
  Written().push_back(out + ".err");
  const int rc = std::system(cmd.c_str());
  EXPECT_EQ(rc, 0) << cmd << "\n"
                   << ReadFile(out + ".err")
                   << "\n(packages missing? scripts/deps.sh runs npm ci in "
                      "tests/ros/mcap_writer)";
  return out;
}

class McapReaderTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const std::string node = SKIMAP_NODE;
    if (node.empty() || access(node.c_str(), X_OK) != 0) {
      GTEST_SKIP() << "node not found (scripts/deps.sh installs it)";
    }
    std::ifstream cams(kScene + "/scene_camera.json");
    ASSERT_TRUE(cams.good()) << kScene;
    cams_ = nlohmann::json::parse(cams);
  }
  void TearDown() override {
    for (const std::string& f : Written()) std::remove(f.c_str());
    Written().clear();
  }

  // Reads every message of the bag in `bytes`, decoded per schema, and checks them.
  void CheckBag(std::string_view bytes, int frames, bool raw_color, bool depth_16uc1);

  nlohmann::json cams_;
};

struct Record {
  uint8_t op;
  uint64_t offset, length;
};

uint64_t U64At(std::string_view b, uint64_t at) {
  uint64_t v = 0;
  for (int i = 7; i >= 0; --i) v = v << 8 | static_cast<uint8_t>(b[at + i]);
  return v;
}
void PutU64(std::string* b, uint64_t at, uint64_t v) {
  for (int i = 0; i < 8; ++i) (*b)[at + i] = static_cast<char>(v >> (8 * i));
}

// The records of the data section, up to and with DataEnd (a test-side scan).
std::vector<Record> DataRecords(std::string_view b) {
  std::vector<Record> out;
  for (uint64_t pos = 8; pos + 9 <= b.size();) {
    Record r{static_cast<uint8_t>(b[pos]), pos, U64At(b, pos + 1)};
    out.push_back(r);
    pos += 9 + r.length;
    if (r.op == 0x0F) break;
  }
  return out;
}

Record FirstRecord(std::string_view b, uint8_t op) {
  for (const Record& r : DataRecords(b)) {
    if (r.op == op) return r;
  }
  ADD_FAILURE() << "no record with opcode " << int(op);
  return {};
}

Eigen::Isometry3d ToIsometry(const geometry_msgs::Transform& t) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() =
      Eigen::Quaterniond(t.rotation.w, t.rotation.x, t.rotation.y, t.rotation.z).toRotationMatrix();
  T.translation() = Eigen::Vector3d(t.translation.x, t.translation.y, t.translation.z);
  return T;
}

std::string ImageName(int id) {
  char name[16];
  std::snprintf(name, sizeof(name), "%06d.png", id);
  return name;
}

void McapReaderTest::CheckBag(std::string_view bytes, int frames, bool raw_color,
                              bool depth_16uc1) {
  auto reader = McapReader::FromBytes(bytes, "bag");
  ASSERT_TRUE(reader.ok()) << reader.status();
  const std::string color_topic =
      raw_color ? "/camera/color/image_raw" : "/camera/color/image_raw/compressed";
  const std::map<std::string, std::string> want = {
      {"/tf_static", "tf2_msgs/msg/TFMessage"},
      {"/tf", "tf2_msgs/msg/TFMessage"},
      {"/camera/color/camera_info", "sensor_msgs/msg/CameraInfo"},
      {"/camera/depth/image_raw", "sensor_msgs/msg/Image"},
      {color_topic, raw_color ? "sensor_msgs/msg/Image" : "sensor_msgs/msg/CompressedImage"}};
  auto channels = (*reader)->Channels();
  ASSERT_TRUE(channels.ok()) << channels.status();
  std::map<std::string, std::string> got;
  for (const McapChannel& c : *channels) {
    got[c.topic] = c.schema_name;
    EXPECT_EQ(c.message_encoding, "cdr");
    EXPECT_EQ(c.schema_encoding, "ros2msg");
  }
  EXPECT_EQ(got, want);

  std::vector<std::string> topics;
  Eigen::Isometry3d link_optical = Eigen::Isometry3d::Identity();
  int frame = -1;
  const absl::Status s = (*reader)->ForEachMessage({}, [&](const McapMessage& m) {
    topics.push_back(m.channel->topic);
    EXPECT_EQ(m.channel->schema_name, want.at(m.channel->topic));
    if (m.channel->topic == "/tf_static") {
      tf2_msgs::TFMessage tf;
      EXPECT_TRUE(DecodeCdr(m.data, &tf).ok());
      EXPECT_EQ(tf.transforms.size(), 1u);
      EXPECT_EQ(tf.transforms[0].header.frame_id, "camera_link");
      EXPECT_EQ(tf.transforms[0].child_frame_id, "camera_color_optical_frame");
      link_optical = ToIsometry(tf.transforms[0].transform);
      return absl::OkStatus();
    }
    if (m.channel->topic == "/tf") ++frame;
    const int id = frame;  // --limit without --every: ids 0, 1, ...
    const nlohmann::json& cam = cams_[std::to_string(id)];
    // The writer's stamp: 1000 s + id / 30 s, nanoseconds rounded.
    const uint64_t stamp_ns =
        (1000ull + id / 30) * 1000000000ull + std::llround(double(id % 30) / 30 * 1e9);
    EXPECT_EQ(m.log_time_ns, stamp_ns) << m.channel->topic;
    if (m.channel->topic == "/tf") {
      tf2_msgs::TFMessage tf;
      EXPECT_TRUE(DecodeCdr(m.data, &tf).ok());
      EXPECT_EQ(tf.transforms[0].header.frame_id, "world");
      EXPECT_EQ(tf.transforms[0].header.stamp.toNSec(), stamp_ns);
      const Eigen::Isometry3d world_optical = ToIsometry(tf.transforms[0].transform) * link_optical;
      Eigen::Matrix3d R;
      for (int i = 0; i < 9; ++i) R(i / 3, i % 3) = cam["cam_R_w2c"][i];
      Eigen::Vector3d t;
      for (int i = 0; i < 3; ++i) t[i] = double(cam["cam_t_w2c"][i]) * 1e-3;
      EXPECT_TRUE(world_optical.linear().isApprox(R.transpose(), 1e-5));  // R to 6 digits
      // Exact to rounding: the quaternions compose to Eigen's quaternion of R^T.
      const auto& a = tf.transforms[0].transform.rotation;
      const Eigen::Quaterniond composed =
          Eigen::Quaterniond(a.w, a.x, a.y, a.z) * Eigen::Quaterniond(link_optical.linear());
      const Eigen::Quaterniond bop(Eigen::Matrix3d(R.transpose()));
      const double sign = composed.coeffs().dot(bop.coeffs()) < 0 ? -1 : 1;  // q ~ -q
      EXPECT_LT((sign * composed.coeffs() - bop.coeffs()).cwiseAbs().maxCoeff(), 1e-15);
      EXPECT_TRUE(world_optical.translation().isApprox(-R.transpose() * t, 1e-12));
    } else if (m.channel->topic == "/camera/color/camera_info") {
      sensor_msgs::CameraInfo info;
      EXPECT_TRUE(DecodeCdr(m.data, &info).ok());
      for (int i = 0; i < 9; ++i) EXPECT_EQ(info.K[i], double(cam["cam_K"][i])) << i;
      EXPECT_EQ(info.header.frame_id, "camera_color_optical_frame");
    } else if (m.channel->topic == "/camera/depth/image_raw") {
      sensor_msgs::Image image;
      EXPECT_TRUE(DecodeCdr(m.data, &image).ok());
      const cv::Mat png = skimap::testing::ImRead(kScene + "/depth/" + ImageName(id),
                                                  skimap::testing::ImageMode::kUnchanged);
      EXPECT_EQ(png.type(), CV_16UC1);
      EXPECT_EQ(image.encoding, depth_16uc1 ? "16UC1" : "32FC1");
      EXPECT_EQ(image.header.frame_id, "camera_color_optical_frame");
      EXPECT_EQ(image.height * image.width * (depth_16uc1 ? 2u : 4u), image.data.size());
      const double scale = cam["depth_scale"];
      int mismatches = 0;
      for (uint32_t y = 0; y < image.height; ++y) {
        for (uint32_t x = 0; x < image.width; ++x) {
          const double raw = png.at<uint16_t>(y, x);
          const uint8_t* p = &image.data[y * image.step + x * (depth_16uc1 ? 2 : 4)];
          if (depth_16uc1) {
            const uint16_t mm = p[0] | p[1] << 8;
            mismatches += mm != uint16_t(std::lround(raw * scale));
          } else {
            float m_;
            std::memcpy(&m_, p, 4);
            mismatches += m_ != float(raw * scale / 1000);
          }
        }
      }
      EXPECT_EQ(mismatches, 0);
    } else if (m.channel->topic == color_topic && raw_color) {
      sensor_msgs::Image image;
      EXPECT_TRUE(DecodeCdr(m.data, &image).ok());
      cv::Mat bgr = skimap::testing::ImRead(kScene + "/rgb/" + ImageName(id),
                                            skimap::testing::ImageMode::kColor),
              rgb;
      cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
      EXPECT_EQ(image.encoding, "rgb8");
      const cv::Mat got(image.height, image.width, CV_8UC3, image.data.data(), image.step);
      EXPECT_EQ(cv::norm(got, rgb(cv::Rect(0, 0, image.width, image.height)), cv::NORM_INF), 0);
    } else if (m.channel->topic == color_topic) {
      sensor_msgs::CompressedImage image;
      EXPECT_TRUE(DecodeCdr(m.data, &image).ok());
      EXPECT_EQ(image.format, "png");
      EXPECT_EQ(std::string(image.data.begin(), image.data.end()),
                ReadFile(kScene + "/rgb/" + ImageName(id)));
    }
    return absl::OkStatus();
  });
  ASSERT_TRUE(s.ok()) << s;
  std::vector<std::string> want_topics = {"/tf_static"};
  for (int i = 0; i < frames; ++i) {
    for (std::string t : {"/tf", "/camera/color/camera_info", "/camera/depth/image_raw"}) {
      want_topics.push_back(t);
    }
    want_topics.push_back(color_topic);
  }
  EXPECT_EQ(topics, want_topics);
}

TEST_F(McapReaderTest, ReadsZstdChunks) {
  CheckBag(ReadFile(WriteBag("--limit 3")), 3, true, true);
}

TEST_F(McapReaderTest, ReadsLz4Chunks) {
  // Small chunks: several per frame, and records split across them.
  CheckBag(ReadFile(WriteBag("--limit 3 --compression lz4 --chunk-size 100000")), 3, true, true);
}

TEST_F(McapReaderTest, ReadsUncompressedChunks) {
  CheckBag(ReadFile(WriteBag("--limit 2 --compression none")), 2, true, true);
}

TEST_F(McapReaderTest, ReadsUnchunkedFloatDepthAndCompressedColour) {
  CheckBag(ReadFile(WriteBag("--limit 2 --unchunked --depth-format 32FC1 --color compressed")), 2,
           false, false);
}

TEST_F(McapReaderTest, OpensFilesAndFiltersTopics) {
  const std::string path = WriteBag("--limit 4 --every 2 --crop 16x12");
  auto reader = McapReader::Open(path);
  ASSERT_TRUE(reader.ok()) << reader.status();
  std::vector<uint64_t> stamps;
  ASSERT_TRUE((*reader)
                  ->ForEachMessage({"/tf", "/nothing"},
                                   [&](const McapMessage& m) {
                                     EXPECT_EQ(m.channel->topic, "/tf");
                                     stamps.push_back(m.log_time_ns);
                                     return absl::OkStatus();
                                   })
                  .ok());
  // --every 2: ids 0, 2, 4, 6.
  EXPECT_EQ(stamps,
            (std::vector<uint64_t>{1000000000000, 1000066666667, 1000133333333, 1000200000000}));
  const absl::Status stop = (*reader)->ForEachMessage(
      {}, [](const McapMessage&) { return absl::CancelledError("enough"); });
  EXPECT_EQ(stop, absl::CancelledError("enough"));

  EXPECT_EQ(McapReader::Open(path + ".missing").status().code(), absl::StatusCode::kNotFound);
  const auto not_mcap = McapReader::Open(kScene + "/scene_camera.json");
  EXPECT_EQ(not_mcap.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(not_mcap.status().message().find("scene_camera.json"), std::string::npos);
}

// Every prefix of a bag: DataLoss naming an offset until the DataEnd record is whole.
void CheckPrefixes(const std::string& bag) {
  const std::vector<Record> records = DataRecords(bag);
  ASSERT_EQ(records.back().op, 0x0F);
  const uint64_t data_end = records.back().offset + 9 + records.back().length;
  for (size_t n = 8; n < bag.size(); n += n < 512 ? 1 : 7) {
    auto reader = McapReader::FromBytes(std::string_view(bag).substr(0, n), "cut.mcap");
    ASSERT_TRUE(reader.ok());
    const absl::Status s =
        (*reader)->ForEachMessage({}, [](const McapMessage&) { return absl::OkStatus(); });
    if (n >= data_end) {
      EXPECT_TRUE(s.ok()) << n << ": " << s;
    } else {
      EXPECT_EQ(s.code(), absl::StatusCode::kDataLoss) << n << ": " << s;
      EXPECT_NE(s.message().find("cut.mcap: "), std::string::npos) << s;
      EXPECT_NE(s.message().find("offset "), std::string::npos) << s;
    }
    auto channels = (*reader)->Channels();  // a summary cut short falls back to scanning
    if (!channels.ok()) {
      EXPECT_EQ(channels.status().code(), absl::StatusCode::kDataLoss) << channels.status();
    }
  }
}

TEST_F(McapReaderTest, EveryPrefixOfAChunkedBagIsDataLossOrComplete) {
  CheckPrefixes(ReadFile(WriteBag("--limit 2 --crop 16x12")));
}

TEST_F(McapReaderTest, EveryPrefixOfAnUnchunkedBagIsDataLossOrComplete) {
  CheckPrefixes(ReadFile(WriteBag("--limit 2 --crop 16x12 --unchunked")));
}

absl::Status ReadAll(std::string_view bag, McapReader::Options options = {}) {
  auto reader = McapReader::FromBytes(bag, "bad.mcap", options);
  if (!reader.ok()) return reader.status();
  return (*reader)->ForEachMessage({}, [](const McapMessage&) { return absl::OkStatus(); });
}

MATCHER_P2(StatusIs, code, text, "") {
  return arg.code() == code && arg.message().find(text) != std::string::npos;
}

TEST_F(McapReaderTest, FlippedByteInAChunkIsACrcMismatch) {
  std::string bag = ReadFile(WriteBag("--limit 1 --crop 16x12 --compression none"));
  const Record chunk = FirstRecord(bag, 0x06);
  bag[chunk.offset + chunk.length / 2] ^= 0x20;
  EXPECT_THAT(ReadAll(bag), StatusIs(absl::StatusCode::kDataLoss, "CRC mismatch"));
  EXPECT_THAT(ReadAll(bag), StatusIs(absl::StatusCode::kDataLoss, "record at offset " +
                                                                      std::to_string(chunk.offset) +
                                                                      " (opcode 0x06 Chunk)"));
}

TEST_F(McapReaderTest, FlippedByteInACompressedChunkIsDataLoss) {
  int flips = 0, at_chunk = 0;
  for (const char* compression : {"zstd", "lz4"}) {
    const std::string good =
        ReadFile(WriteBag(std::string("--limit 1 --crop 16x12 --compression ") + compression));
    const Record chunk = FirstRecord(good, 0x06);
    for (uint64_t i = chunk.offset + 9 + 8 * 3 + 4 + 4 + 4 + 8; i < chunk.offset + 9 + chunk.length;
         ++i) {
      std::string bag = good;
      bag[i] ^= 0x01;
      // Mostly caught at the chunk (decompression or CRC); a flip the decompressor does not
      // see (a window size, an unused bit) leaves the records whole and the data section
      // CRC catches it at DataEnd.
      const absl::Status s = ReadAll(bag);
      EXPECT_THAT(s, StatusIs(absl::StatusCode::kDataLoss, "offset ")) << compression << i;
      at_chunk += s.message().find("offset " + std::to_string(chunk.offset)) != std::string::npos;
      ++flips;
    }
  }
  EXPECT_GT(at_chunk, flips * 9 / 10);
}

TEST_F(McapReaderTest, FlippedByteInAnUnchunkedBagIsADataSectionCrcMismatch) {
  std::string bag = ReadFile(WriteBag("--limit 1 --crop 16x12 --unchunked"));
  const std::vector<Record> records = DataRecords(bag);
  Record last_message{};
  for (const Record& r : records) {
    if (r.op == 0x05) last_message = r;
  }
  bag[last_message.offset + 9 + last_message.length - 1] ^= 0x01;  // image data
  EXPECT_THAT(ReadAll(bag), StatusIs(absl::StatusCode::kDataLoss, "data_section_crc"));
}

TEST_F(McapReaderTest, AbsurdLengthsAreDataLossNamingTheRecord) {
  const std::string good = ReadFile(WriteBag("--limit 1 --crop 16x12"));
  std::string bag = good;
  PutU64(&bag, 8 + 1, ~0ull);  // the Header record right after the magic
  EXPECT_THAT(ReadAll(bag), StatusIs(absl::StatusCode::kDataLoss,
                                     "record at offset 8 (opcode 0x01 Header): declares "
                                     "18446744073709551615 bytes"));
  bag = good;
  const Record chunk = FirstRecord(bag, 0x06);
  PutU64(&bag, chunk.offset + 9 + 8 * 3 + 4 + 4 + 4, ~0ull);  // records length ("zstd")
  EXPECT_THAT(ReadAll(bag), StatusIs(absl::StatusCode::kDataLoss, "truncated Chunk fields"));
}

TEST_F(McapReaderTest, HugeChunksAreRefusedBeforeAllocating) {
  std::string bag = ReadFile(WriteBag("--limit 1 --crop 16x12"));
  const Record chunk = FirstRecord(bag, 0x06);
  PutU64(&bag, chunk.offset + 9 + 16, 1ull << 40);  // uncompressed_size
  EXPECT_THAT(ReadAll(bag), StatusIs(absl::StatusCode::kInvalidArgument,
                                     "uncompressed_size 1099511627776 is over the limit"));
  const std::string good = ReadFile(WriteBag("--limit 1 --crop 16x12"));
  McapReader::Options small;
  small.max_chunk_bytes = 100;
  EXPECT_THAT(ReadAll(good, small), StatusIs(absl::StatusCode::kInvalidArgument, "limit of 100"));
  EXPECT_TRUE(ReadAll(good).ok());
}

TEST_F(McapReaderTest, UnknownCompressionIsInvalidArgument) {
  std::string bag = ReadFile(WriteBag("--limit 1 --crop 16x12"));
  const size_t at = bag.find("zstd", FirstRecord(bag, 0x06).offset);
  ASSERT_NE(at, std::string::npos);
  bag.replace(at, 4, "brot");
  EXPECT_THAT(ReadAll(bag),
              StatusIs(absl::StatusCode::kInvalidArgument, "unsupported compression \"brot\""));
}

TEST_F(McapReaderTest, MessageOnAnUnknownChannelIsDataLoss) {
  std::string bag = ReadFile(WriteBag("--limit 1 --crop 16x12 --unchunked"));
  const Record message = FirstRecord(bag, 0x05);
  bag[message.offset + 9] = 0x77;  // channel_id low byte
  EXPECT_THAT(ReadAll(bag), StatusIs(absl::StatusCode::kDataLoss,
                                     "record at offset " + std::to_string(message.offset) +
                                         " (opcode 0x05 Message): message on unknown channel"));
}

TEST(McapReaderBytesTest, NoMagicIsInvalidArgument) {
  EXPECT_THAT(McapReader::FromBytes("\x89MCAP0\r", "short.mcap").status(),
              StatusIs(absl::StatusCode::kInvalidArgument, "short.mcap: not an MCAP file"));
  EXPECT_THAT(McapReader::FromBytes("", "empty.mcap").status(),
              StatusIs(absl::StatusCode::kInvalidArgument, "empty.mcap"));
}

}  // namespace
}  // namespace skimap::bag
