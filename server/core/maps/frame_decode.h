// Conversion of API frames (skimap.v1.Frame) into decoded perception frames.
//
// Thread safety: pure functions.
#ifndef SERVER_CORE_MAPS_FRAME_DECODE_H_
#define SERVER_CORE_MAPS_FRAME_DECODE_H_

#include "absl/status/statusor.h"
#include "perception/rgbd_frame.h"
#include "skimap/v1/frames.pb.h"

namespace skimap::server {

// The pose as given (no normalization). InvalidArgument ("pose: ...") when the field is
// absent or not a finite rigid transform with a unit quaternion.
absl::StatusOr<perception::CameraPose> DecodePose(const v1::Pose& pose, bool present);

// Decodes and validates everything but the map name and sequence: intrinsics, pose,
// depth_scale, depth and colour images. InvalidArgument naming the field otherwise.
absl::StatusOr<perception::RgbdFrame> DecodeFrame(const v1::Frame& frame);

// DecodeFrame in three steps, each into *out reusing its image buffers (the map's worker
// decodes a frame's depth and colour at once, ahead of integration: live_map.h). DecodeFrame
// equals Header, then Depth, then Colour, the first error winning; Depth and Colour touch
// disjoint members of *out, so they may run concurrently.
// Intrinsics, pose and depth_scale.
absl::Status DecodeFrameHeader(const v1::Frame& frame, perception::RgbdFrame* out);
// depth_encoding and depth. REQUIRES: DecodeFrameHeader(frame, out) is OK.
absl::Status DecodeFrameDepth(const v1::Frame& frame, perception::RgbdFrame* out);
// color_encoding and color (out->color reset when there is none). REQUIRES: as Depth.
absl::Status DecodeFrameColor(const v1::Frame& frame, perception::RgbdFrame* out);
// The three in order, into *out (unspecified on error).
absl::Status DecodeFrameInto(const v1::Frame& frame, perception::RgbdFrame* out);

}  // namespace skimap::server

#endif  // SERVER_CORE_MAPS_FRAME_DECODE_H_
