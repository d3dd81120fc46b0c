// BagFrameSource: a ROS 1 or ROS 2 bag as `skimap stream`'s frames (ros/bag/bag_frames.h
// pairs, poses and converts; this reads ahead on its own thread and encodes the depth the
// way the stream sends it).
//
// Thread safety: FrameSource's (one caller at a time).
#ifndef CLIENT_CLI_BAG_FRAME_SOURCE_H_
#define CLIENT_CLI_BAG_FRAME_SOURCE_H_

#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "client/cli/frame_source.h"
#include "ros/bag/bag_frames.h"

namespace skimap::client {

// Opens the bag at `path` (ros/bag/bag_reader.h) and chooses its topics: NotFound,
// InvalidArgument (not a bag, ambiguous or missing topics, naming the flag to choose
// with), DataLoss (a corrupt index). Frames carry depth as `depth_encoding`.
absl::StatusOr<std::unique_ptr<FrameSource>> OpenBagFrameSource(const std::string& path,
                                                                const bag::BagFrameOptions& options,
                                                                v1::DepthEncoding depth_encoding);

}  // namespace skimap::client

#endif  // CLIENT_CLI_BAG_FRAME_SOURCE_H_
