// RVL depth codec (codec/rvl_codec.h): exact round trips on the real ycbv-0000 depth
// images and on edge cases, and the decoder's refusals of anything the encoder would not
// write.
#include "codec/rvl_codec.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <vector>

#include "codec/image_codec.h"

namespace skimap::perception {
namespace {

std::vector<uint16_t> RoundTrip(const std::vector<uint16_t>& pixels) {
  const std::string bytes = EncodeRvl(pixels.data(), pixels.size());
  EXPECT_EQ(bytes.size() % 4, 0u);
  std::vector<uint16_t> back(pixels.size(), 12345);
  const absl::Status s = DecodeRvl(bytes, back.data(), back.size());
  EXPECT_TRUE(s.ok()) << s;
  return back;
}

absl::StatusCode DecodeCode(const std::string& bytes, size_t count) {
  std::vector<uint16_t> out(count);
  return DecodeRvl(bytes, out.data(), out.size()).code();
}

// Builds a stream word by word from nibbles (most significant first), as the format says.
std::string Nibbles(const std::vector<uint32_t>& nibbles) {
  std::string out;
  for (size_t i = 0; i < nibbles.size(); i += 8) {
    uint32_t word = 0;
    for (size_t j = 0; j < 8; ++j) word = word << 4 | (i + j < nibbles.size() ? nibbles[i + j] : 0);
    for (int b = 0; b < 4; ++b) out.push_back(static_cast<char>(word >> (8 * b)));
  }
  return out;
}

TEST(RvlCodecTest, RoundTripsEveryRealYcbvDepthImageExactly) {
  const std::filesystem::path dir =
      std::filesystem::path(SKIMAP_YCBV_DIR) / "test" / "000000" / "depth";
  ASSERT_TRUE(std::filesystem::is_directory(dir)) << dir;
  int images = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    std::ifstream in(entry.path(), std::ios::binary);
    std::stringstream png;
    png << in.rdbuf();
    absl::StatusOr<DepthImage> depth = DecodeDepth(DepthCodec::kPng16, png.str(), 640, 480);
    ASSERT_TRUE(depth.ok()) << depth.status();
    const std::string rvl = EncodeRvl(depth->pixels.data(), depth->pixels.size());
    // A real sensor frame compresses to less than half its raw size.
    const size_t raw_bytes = depth->pixels.size() * 2;
    EXPECT_LT(rvl.size(), raw_bytes / 2) << entry.path();
    absl::StatusOr<DepthImage> back = DecodeDepth(DepthCodec::kRvl, rvl, 640, 480);
    ASSERT_TRUE(back.ok()) << back.status();
    EXPECT_EQ(back->pixels, depth->pixels) << entry.path();
    ++images;
  }
  EXPECT_EQ(images, 10);
}

TEST(RvlCodecTest, RoundTripsEdgeCases) {
  // All zero (one zero run, an empty value run), all at the maximum, extreme deltas.
  EXPECT_EQ(RoundTrip(std::vector<uint16_t>(640 * 480, 0)), std::vector<uint16_t>(640 * 480, 0));
  EXPECT_EQ(EncodeRvl(std::vector<uint16_t>(640 * 480, 0).data(), 640 * 480).size(), 4u);
  const std::vector<uint16_t> max(1000, 65535);
  EXPECT_EQ(RoundTrip(max), max);
  std::vector<uint16_t> swing(999);
  for (size_t i = 0; i < swing.size(); ++i) swing[i] = i % 2 ? 65535 : 1;
  EXPECT_EQ(RoundTrip(swing), swing);
  // Starts with a value, ends with a value, a lone pixel either way, nothing at all.
  EXPECT_EQ(RoundTrip({7, 0, 0, 9}), std::vector<uint16_t>({7, 0, 0, 9}));
  EXPECT_EQ(RoundTrip({0}), std::vector<uint16_t>({0}));
  EXPECT_EQ(RoundTrip({65535}), std::vector<uint16_t>({65535}));
  EXPECT_EQ(EncodeRvl(nullptr, 0), "");
  EXPECT_TRUE(DecodeRvl("", nullptr, 0).ok());
}

TEST(RvlCodecTest, RoundTripsOddWidthsThroughTheImageCodec) {
  std::mt19937 rng(15);
  for (const auto& [w, h] :
       std::vector<std::pair<int, int>>{{1, 1}, {1, 7}, {3, 5}, {641, 3}, {637, 481}}) {
    DepthImage d{w, h, std::vector<uint16_t>(size_t(w) * h)};
    for (uint16_t& p : d.pixels) p = rng() % 3 == 0 ? 0 : uint16_t(rng());
    absl::StatusOr<std::string> bytes = EncodeDepth(DepthCodec::kRvl, d);
    ASSERT_TRUE(bytes.ok()) << bytes.status();
    absl::StatusOr<DepthImage> back = DecodeDepth(DepthCodec::kRvl, *bytes, w, h);
    ASSERT_TRUE(back.ok()) << w << "x" << h << ": " << back.status();
    EXPECT_EQ(back->pixels, d.pixels) << w << "x" << h;
    // The stream says how many pixels it covers: another size is refused.
    EXPECT_EQ(DecodeDepth(DepthCodec::kRvl, *bytes, w + 1, h).status().code(),
              absl::StatusCode::kInvalidArgument);
  }
}

TEST(RvlCodecTest, RefusesWhatTheEncoderWouldNotWrite) {
  const std::vector<uint16_t> pixels = {0, 0, 5, 6, 0, 9};
  const std::string good = EncodeRvl(pixels.data(), pixels.size());
  // The hand-built form of `good`: runs (2, 2), +5, +1, runs (1, 1), +3.
  ASSERT_EQ(good, Nibbles({2, 2, 2 | 8, 1, 2, 1, 1, 6}));
  EXPECT_EQ(DecodeCode(good, 6), absl::StatusCode::kOk);
  const auto bad = absl::StatusCode::kInvalidArgument;
  EXPECT_EQ(DecodeCode(good.substr(0, 3), 6), bad);                         // not whole words
  EXPECT_EQ(DecodeCode(good + std::string(4, '\0'), 6), bad);               // a word after the end
  EXPECT_EQ(DecodeCode(good, 5), bad);                                      // a run past the image
  EXPECT_EQ(DecodeCode(good, 7), bad);                                      // ends early
  EXPECT_EQ(DecodeCode(Nibbles({2, 2, 2 | 8, 1, 2, 1, 1, 6, 1}), 6), bad);  // padding not zero
  EXPECT_EQ(DecodeCode(Nibbles({0, 0}), 1), bad);                           // an empty pair of runs
  EXPECT_EQ(DecodeCode(Nibbles({1, 0, 1, 0}), 2), bad);      // an empty value run mid-image
  EXPECT_EQ(DecodeCode(Nibbles({0, 2, 2, 1}), 2), bad);      // a zero inside a value run
  EXPECT_EQ(DecodeCode(Nibbles({0, 1, 1}), 1), bad);         // value -1
  EXPECT_EQ(DecodeCode(Nibbles({0 | 8, 0, 1, 2}), 1), bad);  // a non-minimal VLE
  EXPECT_EQ(DecodeCode(Nibbles(std::vector<uint32_t>(12, 8)), 1), bad);  // an over-long VLE
  std::vector<uint16_t> out(7);
  const absl::Status s = DecodeRvl(good, out.data(), out.size());
  EXPECT_NE(s.message().find("depth: RVL"), std::string::npos) << s;
}

}  // namespace
}  // namespace skimap::perception
