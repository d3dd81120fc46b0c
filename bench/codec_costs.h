// Sections 1 and 1b of ingest_bench (docs/benchmarks.md, "Ingestion"): what each depth and colour
// codec costs per real frame. Every depth codec is checked to give back exactly the
// pixels it was given; the program stops otherwise.
#ifndef BENCH_CODEC_COSTS_H_
#define BENCH_CODEC_COSTS_H_

#include <string>
#include <vector>

#include "bench/ycbv_frames.h"

namespace skimap::bench {

// Prints a Markdown table: bytes, ratio to raw, median encode and decode ms over reps x
// the frames, per codec (codec/image_codec.h, the server's own decoders).
void PrintCodecCosts(const std::vector<RealFrame>& frames, int reps);

// Prints a Markdown table: the median ms to decode each folder's PNG files (up to 20) as
// stored, with our decoder (codec/image_files.h: the libdeflate fast path) and with libpng
// alone; stops when the two give different pixels.
void PrintPngDecoders(const std::vector<std::string>& dirs, int reps);

}  // namespace skimap::bench

#endif  // BENCH_CODEC_COSTS_H_
