// Depth images onto API frames, as a client sends them: zstd (level 1) of the raw
// little-endian pixels by default (of the lossless codecs the fastest to decode on the
// server and the smallest on the wire, and as fast as RVL to encode here: docs/api.md,
// "Depth and colour encodings"), or RVL, 16-bit PNG or raw uint16 when asked.
//
//   v1::Frame frame;  // intrinsics, pose, depth_scale set by the caller
//   absl::Status s = SetFrameDepth(pixels.data(), 640, 480, &frame);  // zstd
//
// Thread safety: pure functions of their arguments.
#ifndef CLIENT_FRAME_DEPTH_H_
#define CLIENT_FRAME_DEPTH_H_

#include <cstdint>

#include "absl/status/status.h"
#include "skimap/v1/frames.pb.h"

namespace skimap::client {

// The depth encoding clients send unless told otherwise.
inline constexpr v1::DepthEncoding kDefaultDepthEncoding = v1::DEPTH_ENCODING_ZSTD;
// For a client that holds depth as an encoded file (the CLI's dataset folders): a 16-bit
// greyscale PNG goes as stored (PNG16), anything else decoded and re-encoded with
// kDefaultDepthEncoding. The server inflates a PNG with libdeflate about as fast as it
// unpacks zstd, and the client then neither decodes nor encodes (docs/api.md, "Depth and
// colour encodings"). Not a wire value: SetFrameDepth refuses it.
inline constexpr v1::DepthEncoding kDepthAsStored = v1::DEPTH_ENCODING_UNSPECIFIED;

// Encodes width x height depth pixels (row-major, sensor units, 0 = no measurement) with
// `encoding` into frame->depth and sets frame->depth_encoding. InvalidArgument for a size
// outside 1..8192 or an unknown encoding ("depth_encoding"); Internal if PNG or zstd
// encoding fails. Leaves the frame unchanged on error.
absl::Status SetFrameDepth(const uint16_t* pixels, int width, int height, v1::Frame* frame,
                           v1::DepthEncoding encoding = kDefaultDepthEncoding);

}  // namespace skimap::client

#endif  // CLIENT_FRAME_DEPTH_H_
