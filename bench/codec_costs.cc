#include "bench/codec_costs.h"

#include <cstdio>
#include <cstdlib>
#include <string>

#include "bench/samples.h"
#include "codec/image_codec.h"

namespace skimap::bench {
namespace {

[[noreturn]] void StopCodecCosts(const char* what) {
  std::fprintf(stderr, "codec costs: %s\n", what);
  std::exit(1);
}

}  // namespace

void PrintCodecCosts(const std::vector<RealFrame>& frames, int reps) {
  std::printf("\n### Codec costs (640x480 ycbv, per frame, median of %d x %zu)\n\n", reps,
              frames.size());
  std::printf(
      "| image | codec | bytes | ratio | encode ms | decode ms |\n|---|---|---|---|---|---|\n");
  const perception::DepthCodec depth_codecs[] = {
      perception::DepthCodec::kRawU16, perception::DepthCodec::kPng16,
      perception::DepthCodec::kZstd, perception::DepthCodec::kRvl};
  const char* depth_names[] = {"RAW_U16", "PNG16", "ZSTD (level 1)", "RVL"};
  const perception::ColorCodec color_codecs[] = {perception::ColorCodec::kRawRgb8,
                                                 perception::ColorCodec::kPng,
                                                 perception::ColorCodec::kJpeg};
  const char* color_names[] = {"RAW_RGB8", "PNG", "JPEG q90"};
  for (int c = 0; c < 4; ++c) {
    Samples enc, dec;
    double bytes = 0;
    for (int r = 0; r < reps; ++r) {
      for (const RealFrame& f : frames) {
        const Clock::time_point t0 = Clock::now();
        absl::StatusOr<std::string> b = perception::EncodeDepth(depth_codecs[c], f.depth);
        const Clock::time_point t1 = Clock::now();
        absl::StatusOr<perception::DepthImage> d =
            perception::DecodeDepth(depth_codecs[c], *b, f.depth.width, f.depth.height);
        const Clock::time_point t2 = Clock::now();
        if (!d.ok() || d->pixels != f.depth.pixels) StopCodecCosts("depth codec is not lossless");
        enc.Add(Ms(t1 - t0));
        dec.Add(Ms(t2 - t1));
        bytes += double(b->size());
      }
    }
    bytes /= double(reps * frames.size());
    std::printf("| depth | %s | %.0f | %.2f | %.2f | %.2f |\n", depth_names[c], bytes,
                double(frames[0].depth.pixels.size() * 2) / bytes, enc.Median(), dec.Median());
  }
  for (int c = 0; c < 3; ++c) {
    Samples enc, dec;
    double bytes = 0;
    for (int r = 0; r < reps; ++r) {
      for (const RealFrame& f : frames) {
        const Clock::time_point t0 = Clock::now();
        absl::StatusOr<std::string> b = perception::EncodeColor(color_codecs[c], f.color);
        const Clock::time_point t1 = Clock::now();
        absl::StatusOr<perception::ColorImage> d =
            perception::DecodeColor(color_codecs[c], *b, f.color.width, f.color.height);
        const Clock::time_point t2 = Clock::now();
        if (!d.ok()) StopCodecCosts("colour does not decode");
        enc.Add(Ms(t1 - t0));
        dec.Add(Ms(t2 - t1));
        bytes += double(b->size());
      }
    }
    bytes /= double(reps * frames.size());
    std::printf("| colour | %s | %.0f | %.2f | %.2f | %.2f |\n", color_names[c], bytes,
                double(frames[0].color.rgb.size()) / bytes, enc.Median(), dec.Median());
  }
}

}  // namespace skimap::bench
