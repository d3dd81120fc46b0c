// `skimap stream`: sends a dataset's frames to a map over StreamFrames with a progress
// line, then prints a summary (frames ok / failed, frames/s, the map's stats).
//
// Thread safety: one call at a time per MapClient stream (the client itself is shared).
#ifndef CLIENT_CLI_STREAM_COMMAND_H_
#define CLIENT_CLI_STREAM_COMMAND_H_

#include <optional>
#include <string>

#include "absl/status/status.h"
#include "client/cli/frame_source.h"
#include "client/frame_depth.h"
#include "client/map_client.h"

namespace skimap::client {

struct StreamOptions {
  std::string map_id;        // created with `resolution` when it does not exist
  double fps = 0;            // pacing; 0 = as fast as the server acknowledges
  double resolution = 0.05;  // metres, only used to create the map
  // More options of a map this stream creates (the fields set; resolution and recognition
  // come from their own fields). Into an existing map, every field set here must agree
  // with the map's (FailedPrecondition naming the first that does not).
  v1::MapOptions map_options;
  int window = 8;      // frames in flight
  bool quiet = false;  // no progress line; the summary on stderr, not stdout
  int every = 1;       // send every n-th frame of the dataset
  int max_frames = 0;  // send at most this many; 0 = all
  // Recognition on the map, when this stream creates it (an existing map keeps its own).
  std::optional<v1::RecognitionOptions> recognition;
  // Depth on the wire (FrameSourceOptions): a dataset's 16-bit PNG files as stored and
  // anything else as zstd unless told.
  v1::DepthEncoding depth_encoding = kDepthAsStored;
  BagSourceOptions bag;  // topics, frames and pairing of a ROS bag
};

// OK when every frame was acknowledged OK; otherwise the first error (after streaming all).
absl::Status StreamDataset(MapClient& client, const std::string& dataset_path,
                           const StreamOptions& options);

}  // namespace skimap::client

#endif  // CLIENT_CLI_STREAM_COMMAND_H_
