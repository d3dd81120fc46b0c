// BagFrameSource: a ROS 1 or ROS 2 bag as `skimap stream`'s frames (ros/bag/bag_frames.h
// pairs, poses and converts; this reads ahead on its own thread and encodes the depth the
// way the stream sends it).
//
// ROS 1 bags are read by Debian's rosbag library, which a hostile file can crash (a
// fuzzer found a 45-byte bag on which ros::Header::parse reads past its buffer; the input
// is tests/ros/data/rosbag_header_overread.bag). So before this process reads a ROS 1 bag,
// a child process (this binary, `skimap __read-ros1-bag PATH`, posix_spawn'd: safe beside
// the client's threads) reads it whole; a child killed by a signal, or still reading after
// its time limit (then killed), makes the bag refused by name. The price: a ROS 1 bag is
// read twice.
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
// with; a ROS 1 bag whose check crashed or outlasted `check_seconds`, 0 = 60 s plus 1 s
// per 20 MB), DataLoss (a corrupt index). Frames carry depth as `depth_encoding`
// (kDepthAsStored: kDefaultDepthEncoding).
absl::StatusOr<std::unique_ptr<FrameSource>> OpenBagFrameSource(const std::string& path,
                                                                const bag::BagFrameOptions& options,
                                                                v1::DepthEncoding depth_encoding,
                                                                double check_seconds);

// The child's side: reads every message of the frame topics of the ROS 1 bag at `path`;
// returns the process's exit status (0 read, 1 refused with an error). `skimap` runs it
// for the hidden command `__read-ros1-bag PATH`.
int ReadRos1BagInThisProcess(const std::string& path);

}  // namespace skimap::client

#endif  // CLIENT_CLI_BAG_FRAME_SOURCE_H_
