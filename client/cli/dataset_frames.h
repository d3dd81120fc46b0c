// Conversion of dataset frames (dataset/reader.h: BOP scenes, TUM sequences, sim output)
// into API frames: depth re-encoded as RVL by default (client/frame_depth.h) or sent as
// stored (16-bit PNG) when asked; colour sent as stored (PNG or JPEG).
//
// Thread safety: functions of their arguments.
#ifndef CLIENT_CLI_DATASET_FRAMES_H_
#define CLIENT_CLI_DATASET_FRAMES_H_

#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "client/frame_depth.h"
#include "dataset/types.h"
#include "skimap/v1/frames.pb.h"
#include "skimap/v1/objects.pb.h"

namespace skimap::client {

// The frames of a dataset folder: a BOP scene or TUM sequence folder, or a BOP dataset
// root (every scene of every split, in order). NotFound / InvalidArgument from the reader.
absl::StatusOr<std::vector<dataset::Frame>> LoadDatasetFrames(const std::string& path);

// Every `every`-th frame of `frames` from the first, at most max_frames (0: all): the
// frames `skimap stream` and `skimap eval` send.
std::vector<dataset::Frame> KeepEvery(std::vector<dataset::Frame> frames, int every,
                                      int max_frames);

// Reads the frame's files into a Frame for `map_name` with `sequence`, depth with
// `depth_encoding` (kDepthAsStored: a 16-bit greyscale PNG as stored, any other file
// re-encoded with zstd; PNG16: the file's bytes as stored, unchecked; ZSTD / RVL / RAW_U16:
// decoded and re-encoded). FailedPrecondition if the frame has no pose or no depth image;
// NotFound for a missing file; InvalidArgument if a depth file to decode is not a 16-bit
// PNG or the encoding is none of these.
absl::StatusOr<v1::Frame> ToApiFrame(const dataset::Frame& frame, const std::string& map_name,
                                     uint64_t sequence,
                                     v1::DepthEncoding depth_encoding = kDepthAsStored);

// The frame's colour image as stored (PNG or JPEG) in a ClassifyImage request that asks
// for the 2D-3D matches (the single-view baseline: client/cli/single_view.h). NotFound for a
// missing file; FailedPrecondition if the frame has no colour image or no image size.
absl::StatusOr<v1::ClassifyImageRequest> ToClassifyImageRequest(const dataset::Frame& frame);

// Writes a rigid transform as an API pose (unit quaternion w, x, y, z + translation, m).
void ToApiPose(const Eigen::Isometry3d& T, v1::Pose* pose);

}  // namespace skimap::client

#endif  // CLIENT_CLI_DATASET_FRAMES_H_
