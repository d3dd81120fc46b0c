#include "bench/codec_costs.h"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "absl/strings/str_cat.h"
#include "bench/samples.h"
#include "codec/image_codec.h"
#include "codec/image_files.h"
#include "codec/image_formats.h"
#include "codec/image_header.h"

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

void PrintPngDecoders(const std::vector<std::string>& dirs, int reps) {
  std::printf(
      "\n### PNG files as stored: our decoder (libdeflate fast path) and libpng alone (median "
      "ms per file of %d reps)\n\n| folder | files | layout | ours | libpng alone | libpng / "
      "ours |\n|---|---|---|---|---|---|\n",
      reps);
  for (const std::string& dir : dirs) {
    std::vector<std::string> paths;
    std::error_code error;
    for (const auto& e : std::filesystem::directory_iterator(dir, error)) {
      if (e.path().extension() == ".png") paths.push_back(e.path().string());
    }
    std::sort(paths.begin(), paths.end());
    if (paths.size() > 20) paths.resize(20);
    if (paths.empty()) StopCodecCosts(("no PNG files in " + dir).c_str());
    Samples ours, libpng;
    std::string layout;
    for (const std::string& path : paths) {
      std::ifstream in(path, std::ios::binary);
      const std::string bytes((std::istreambuf_iterator<char>(in)), {});
      // Depth as the dataset readers read it (any depth), colour as the wire decodes it.
      const perception::ImageMode mode =
          perception::ReadImageHeader(perception::ImageFormat::kPng, bytes, "png")
                      .value_or(perception::ImageHeader{})
                      .channels == 1
              ? perception::ImageMode::kAnyDepth
              : perception::ImageMode::kRgb;
      for (int r = 0; r < reps; ++r) {
        cv::Mat a, l;
        const Clock::time_point t0 = Clock::now();
        const absl::Status sa = perception::DecodeImageInto(bytes, mode, &a);
        const Clock::time_point t1 = Clock::now();
        const absl::Status sl = perception::image_formats::DecodePngWithLibpng(bytes, mode, &l);
        const Clock::time_point t2 = Clock::now();
        if (!sa.ok() || !sl.ok() || a.size() != l.size() || a.type() != l.type() ||
            cv::norm(a, l, cv::NORM_INF) != 0) {
          StopCodecCosts(("our PNG decoder and libpng give different pixels: " + path).c_str());
        }
        layout = absl::StrCat(a.cols, "x", a.rows, a.depth() == CV_16U ? " 16-bit" : " 8-bit", " x",
                              a.channels());
        ours.Add(Ms(t1 - t0));
        libpng.Add(Ms(t2 - t1));
      }
    }
    std::printf("| %s | %zu | %s | %.2f | %.2f | %.2fx |\n", dir.c_str(), paths.size(),
                layout.c_str(), ours.Median(), libpng.Median(), libpng.Median() / ours.Median());
  }
}

}  // namespace skimap::bench
