// The real RGB-D frames the ingestion benchmarks send: the 10 640x480 frames of
// ycbv-0000 (BOP layout), decoded once, then encoded per codec combination exactly as a
// client sends them (skimap.v1.Frame with depth and colour bytes).
//
//   std::vector<RealFrame> frames = LoadYcbvFrames(dir);        // exits on error
//   EncodedFrames rvl_jpeg(frames, kRvlJpeg);
//   v1::Frame f = rvl_jpeg.Make(k, "maps/m", k + 1, Shift{.x = 10.0 * k});  // new space
//
// Thread safety: plain functions and values.
#ifndef BENCH_YCBV_FRAMES_H_
#define BENCH_YCBV_FRAMES_H_

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "codec/image_codec.h"
#include "perception/rgbd_frame.h"
#include "skimap/v1/frames.pb.h"

namespace skimap::bench {

// One real frame, decoded, and its API form (pose, intrinsics, depth_scale; no images).
struct RealFrame {
  v1::Frame api;
  perception::DepthImage depth;
  perception::ColorImage color;
};

// The frame as the server's stages take it (decoded, with its camera and pose).
perception::RgbdFrame ToRgbdFrame(const RealFrame& f);

// The frames of the BOP dataset at `root` (every `every`-th, at most `limit`); prints the
// error and exits when it does not load.
std::vector<RealFrame> LoadYcbvFrames(const std::string& root, size_t every = 1,
                                      size_t limit = SIZE_MAX);

struct Codec {
  const char* name;
  v1::DepthEncoding depth;
  v1::ColorEncoding color;
};
inline constexpr Codec kZstdJpeg{"zstd + JPEG", v1::DEPTH_ENCODING_ZSTD,
                                 v1::COLOR_ENCODING_JPEG};  // the client library's default
inline constexpr Codec kRvlJpeg{"RVL + JPEG", v1::DEPTH_ENCODING_RVL, v1::COLOR_ENCODING_JPEG};
inline constexpr Codec kPng16Jpeg{"PNG16 + JPEG", v1::DEPTH_ENCODING_PNG16,
                                  v1::COLOR_ENCODING_JPEG};

perception::DepthCodec ToDepthCodec(v1::DepthEncoding e);
perception::ColorCodec ToColorCodec(v1::ColorEncoding e);

// World translation added to a frame's pose.
struct Shift {
  double x = 0, y = 0, z = 0;
};

// The frames encoded once with one codec; Make(k, ...) gives frame k of a sequence:
// frames[k % n] with those bytes, its pose moved by `shift`.
class EncodedFrames {
 public:
  EncodedFrames(const std::vector<RealFrame>& frames, const Codec& codec);
  v1::Frame Make(size_t k, const std::string& map, uint64_t sequence, const Shift& shift) const;
  // Mean bytes of a frame's message.
  double mean_bytes() const;

 private:
  std::vector<v1::Frame> encoded_;
};

// `count` frames of a sequence (EncodedFrames::Make), frame k with sequence k + 1 and its
// pose moved by shift(k).
std::vector<std::shared_ptr<const v1::Frame>> EncodeFrames(
    const std::vector<RealFrame>& frames, const Codec& codec, size_t count,
    const std::function<Shift(size_t)>& shift);

}  // namespace skimap::bench

#endif  // BENCH_YCBV_FRAMES_H_
