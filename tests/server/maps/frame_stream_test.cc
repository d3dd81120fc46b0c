// StreamFrames over real gRPC: every kind of bad frame gets its status in its ack and the
// stream goes on.
#include <algorithm>
#include <cstring>
#include <functional>
#include <limits>
#include <map>

#include "codec/image_files.h"
#include "codec/zstd_frame.h"
#include "tests/common/synthetic_scene.h"
#include "tests/server/maps/server_fixture.h"

namespace skimap::testing {
namespace {

struct BadFrame {
  std::string name;
  std::function<void(v1::Frame&)> mutate;
  absl::StatusCode code;
  std::string field;  // must appear in the message
};

// Replaces the frame's depth with `raw` as one zstd frame less its last `cut` bytes, then
// `tail`.
void SetZstdDepth(v1::Frame& f, const std::string& raw, size_t cut = 0,
                  const std::string& tail = "") {
  const std::string packed = *perception::ZstdCompress(raw);
  f.set_depth_encoding(v1::DEPTH_ENCODING_ZSTD);
  f.set_depth(packed.substr(0, packed.size() - std::min(cut, packed.size())) + tail);
}

// Replaces the frame's raw depth with the same pixels as a 16-bit PNG (what `skimap stream`
// sends for a dataset's depth files, as stored) less its last `cut` bytes; with `flip`, one
// byte in the middle changed (a chunk's CRC then fails).
void SetPngDepth(v1::Frame& f, size_t cut, bool flip = false) {
  cv::Mat pixels(static_cast<int>(f.intrinsics().height()),
                 static_cast<int>(f.intrinsics().width()), CV_16UC1);
  std::memcpy(pixels.data, f.depth().data(), std::min(f.depth().size(), pixels.total() * 2));
  std::string png = *perception::EncodeImage(".png", pixels);
  if (flip) png[png.size() / 2] = static_cast<char>(png[png.size() / 2] ^ 0x5a);
  f.set_depth_encoding(v1::DEPTH_ENCODING_PNG16);
  f.set_depth(png.substr(0, png.size() - std::min(cut, png.size())));
}

TEST_F(ServerTest, BadFramesGetTheirStatusAndTheStreamContinues) {
  CreateMap("stream");
  const v1::Frame good = MakeFrame("maps/stream", 0, DefaultView());
  const double nan = std::numeric_limits<double>::quiet_NaN();
  using Code = absl::StatusCode;
  const std::vector<BadFrame> bad = {
      {"unknown map", [](v1::Frame& f) { f.set_map("maps/nope"); }, Code::kNotFound, "maps/nope"},
      {"bad map name", [](v1::Frame& f) { f.set_map("stream"); }, Code::kInvalidArgument, "map"},
      {"zero fx", [](v1::Frame& f) { f.mutable_intrinsics()->set_fx(0); }, Code::kInvalidArgument,
       "intrinsics.fx"},
      {"no intrinsics", [](v1::Frame& f) { f.clear_intrinsics(); }, Code::kInvalidArgument,
       "intrinsics"},
      {"huge width", [](v1::Frame& f) { f.mutable_intrinsics()->set_width(100000); },
       Code::kInvalidArgument, "intrinsics.width"},
      {"non-unit quaternion", [](v1::Frame& f) { f.mutable_pose()->mutable_rotation()->set_w(2); },
       Code::kInvalidArgument, "pose.rotation"},
      {"no pose", [](v1::Frame& f) { f.clear_pose(); }, Code::kInvalidArgument, "pose"},
      {"nan translation",
       [nan](v1::Frame& f) { f.mutable_pose()->mutable_translation()->set_x(nan); },
       Code::kInvalidArgument, "pose.translation"},
      {"zero depth scale", [](v1::Frame& f) { f.set_depth_scale(0); }, Code::kInvalidArgument,
       "depth_scale"},
      {"truncated raw depth", [](v1::Frame& f) { f.mutable_depth()->resize(100); },
       Code::kInvalidArgument, "depth"},
      {"garbage png depth",
       [](v1::Frame& f) {
         f.set_depth_encoding(v1::DEPTH_ENCODING_PNG16);
         f.set_depth("not a png");
       },
       Code::kInvalidArgument, "depth"},
      {"garbage zstd depth",
       [](v1::Frame& f) {
         f.set_depth_encoding(v1::DEPTH_ENCODING_ZSTD);
         f.set_depth("not zstd at all");
       },
       Code::kInvalidArgument, "depth"},
      // The client's default encoding, damaged: the frame's own raw pixels as zstd, cut
      // short, followed by junk, or claiming half or twice the image's bytes.
      {"truncated zstd depth", [](v1::Frame& f) { SetZstdDepth(f, f.depth(), 5); },
       Code::kInvalidArgument, "depth"},
      {"zstd depth with trailing junk", [](v1::Frame& f) { SetZstdDepth(f, f.depth(), 0, "junk"); },
       Code::kInvalidArgument, "depth"},
      {"zstd depth of half the image",
       [](v1::Frame& f) { SetZstdDepth(f, f.depth().substr(0, f.depth().size() / 2)); },
       Code::kInvalidArgument, "depth"},
      {"zstd depth of twice the image",
       [](v1::Frame& f) { SetZstdDepth(f, f.depth() + f.depth()); }, Code::kInvalidArgument,
       "depth"},
      // The CLI's default for a dataset's depth files (sent as stored), damaged on disk.
      {"truncated png depth", [](v1::Frame& f) { SetPngDepth(f, 100); }, Code::kInvalidArgument,
       "depth"},
      {"png depth with a bad crc", [](v1::Frame& f) { SetPngDepth(f, 0, true); },
       Code::kInvalidArgument, "depth"},
      {"no depth encoding",
       [](v1::Frame& f) { f.set_depth_encoding(v1::DEPTH_ENCODING_UNSPECIFIED); },
       Code::kInvalidArgument, "depth_encoding"},
      {"short raw colour",
       [](v1::Frame& f) {
         f.set_color_encoding(v1::COLOR_ENCODING_RAW_RGB8);
         f.set_color(std::string(10, 'x'));
       },
       Code::kInvalidArgument, "color"},
      {"garbage jpeg colour",
       [](v1::Frame& f) {
         f.set_color_encoding(v1::COLOR_ENCODING_JPEG);
         f.set_color("\xff\xd8 broken");
       },
       Code::kInvalidArgument, "color"},
      {"colour without encoding", [](v1::Frame& f) { f.set_color("abc"); }, Code::kInvalidArgument,
       "color_encoding"},
      {"oversized", [](v1::Frame& f) { f.set_color(std::string(5 << 20, 'x')); },
       Code::kResourceExhausted, "depth+color"},
      {"duplicate sequence", [](v1::Frame& f) { f.set_sequence(0); }, Code::kAlreadyExists,
       "sequence"},
  };
  std::unique_ptr<client::FrameStream> stream = client_->OpenFrameStream({.window = 3});
  ASSERT_TRUE(stream->Send(good).ok());
  for (size_t i = 0; i < bad.size(); ++i) {
    v1::Frame f = good;
    f.set_sequence(100 + i);
    bad[i].mutate(f);
    ASSERT_TRUE(stream->Send(f).ok()) << bad[i].name;
  }
  v1::Frame last = good;
  last.set_sequence(1);
  ASSERT_TRUE(stream->Send(last).ok());
  v1::Frame png = good;  // the damaged PNGs' undamaged original
  png.set_sequence(2);
  SetPngDepth(png, 0);
  ASSERT_TRUE(stream->Send(png).ok());
  auto acks = stream->Finish();
  ASSERT_TRUE(acks.ok()) << acks.status();
  ASSERT_EQ(acks->size(), bad.size() + 3);
  std::map<uint64_t, v1::FrameAck> by_sequence;
  for (const v1::FrameAck& a : *acks) by_sequence[a.sequence()] = a;
  EXPECT_EQ(by_sequence.at(1).code(), 0) << by_sequence.at(1).message();
  EXPECT_EQ(by_sequence.at(2).code(), 0) << by_sequence.at(2).message();
  for (size_t i = 0; i < bad.size(); ++i) {
    const uint64_t seq = bad[i].name == "duplicate sequence" ? 0 : 100 + i;
    if (seq == 0) continue;  // shares sequence 0 with the good frame; checked below
    const v1::FrameAck& a = by_sequence.at(seq);
    EXPECT_EQ(a.code(), static_cast<int>(bad[i].code)) << bad[i].name << ": " << a.message();
    EXPECT_THAT(a.message(), ::testing::HasSubstr(bad[i].field)) << bad[i].name;
  }
  int zero_ok = 0, zero_exists = 0;  // the good frame 0 and its duplicate
  for (const v1::FrameAck& a : *acks) {
    if (a.sequence() != 0) continue;
    zero_ok += a.code() == 0;
    zero_exists += a.code() == static_cast<int>(absl::StatusCode::kAlreadyExists);
  }
  EXPECT_EQ(zero_ok, 1);
  EXPECT_EQ(zero_exists, 1);
  auto map = client_->GetMap("maps/stream");
  ASSERT_TRUE(map.ok());
  EXPECT_EQ(map->stats().frames(), 3u);  // 0, 1 and the PNG
}

TEST_F(ServerTest, UnaryIntegrateFrameReturnsErrorsAsStatus) {
  CreateMap("unary");
  v1::Frame f = MakeFrame("maps/unary", 1, DefaultView());
  f.set_depth_scale(-1);
  auto ack = client_->IntegrateFrame(f);
  EXPECT_EQ(ack.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(ack.status().message(), ::testing::HasSubstr("depth_scale"));
}

}  // namespace
}  // namespace skimap::testing
