// Conversion of API frames (skimap.v1.Frame) into decoded perception frames.
//
// Thread safety: pure functions.
#ifndef SERVER_MAPS_FRAME_DECODE_H_
#define SERVER_MAPS_FRAME_DECODE_H_

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

}  // namespace skimap::server

#endif  // SERVER_MAPS_FRAME_DECODE_H_
