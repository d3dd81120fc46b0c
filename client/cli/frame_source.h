// FrameSource: where `skimap stream` gets its frames, one at a time, in order: a dataset
// folder (BOP scene, TUM sequence, BOP root) or a ROS bag (ros/bag/: ROS 1 .bag, ROS 2
// MCAP). The stream loop (stream_command.h) sets each frame's map and sequence.
//
// Thread safety: one caller at a time (the stream's producer thread).
#ifndef CLIENT_CLI_FRAME_SOURCE_H_
#define CLIENT_CLI_FRAME_SOURCE_H_

#include <cstddef>
#include <memory>
#include <optional>
#include <string>

#include "absl/status/statusor.h"
#include "client/frame_depth.h"
#include "skimap/v1/frames.pb.h"

namespace skimap::client {

// One frame ready to send (map and sequence unset), or why this one frame could not be
// made (a missing image file): the stream goes on without it and reports the first such
// error at the end.
using FrameOrError = absl::StatusOr<v1::Frame>;

class FrameSource {
 public:
  virtual ~FrameSource() = default;
  // Frames this source yields, when known before reading (the progress bar's total); 0 if
  // not known.
  virtual size_t total() const = 0;
  // The next frame or its error; nullopt after the last; an error status when the source
  // itself cannot go on (a truncated or corrupt bag: the message names the record or
  // topic): the stream stops there, after the frames already sent are acknowledged.
  virtual absl::StatusOr<std::optional<FrameOrError>> Next() = 0;
};

// How a ROS bag becomes frames (ros/bag/bag_frames.h; docs/ros.md, "Bags"): "" = chosen
// from the bag.
struct BagSourceOptions {
  std::string depth_topic, color_topic, camera_info_topic;  // color_topic "-": no colour
  std::string fixed_frame, camera_frame;
  double sync_tolerance = 0.02;  // seconds between a depth image and its colour image
  // A ROS 1 bag is first read by a child process (bag_frame_source.h) for at most this
  // long; 0 = 60 s plus 1 s per 20 MB of bag.
  double check_seconds = 0;
};

// What OpenFrameSource selects and how it encodes (the `skimap stream` flags).
struct FrameSourceOptions {
  int every = 1;       // every n-th frame from the first
  int max_frames = 0;  // at most this many frames; 0 = all
  // Depth on the wire (client/frame_depth.h): kDepthAsStored sends a dataset's 16-bit PNG
  // files as stored and everything else, bags too, as kDefaultDepthEncoding; PNG16 sends a
  // dataset's files as stored.
  v1::DepthEncoding depth_encoding = kDepthAsStored;
  BagSourceOptions bag;
};

// True if `path` names a ROS bag: a file ending in .bag, .mcap or .db3, or a folder holding a
// rosbag2 metadata.yaml.
bool IsBagPath(const std::string& path);

// The source for `path`: a ROS bag (IsBagPath; client/cli/bag_frame_source.h:
// Unimplemented when this skimap was built without ROS) or a dataset folder (BOP scene,
// TUM sequence or BOP root; client/cli/dataset_frame_source.h). NotFound /
// InvalidArgument when `path` is none of them (the reader's message).
absl::StatusOr<std::unique_ptr<FrameSource>> OpenFrameSource(const std::string& path,
                                                             const FrameSourceOptions& options);

}  // namespace skimap::client

#endif  // CLIENT_CLI_FRAME_SOURCE_H_
