// BridgeParams: the skimap-ros node's private parameters (docs/ros.md lists them), read
// and checked by ReadParams, and the checks of what its services are handed.
//
//   absl::StatusOr<BridgeParams> params = ReadParams(ros::NodeHandle("~"));
//
// Thread safety: pure functions over their arguments (ReadParams reads the parameter
// server through `private_nh`).
#ifndef ROS_BRIDGE_BRIDGE_PARAMS_H_
#define ROS_BRIDGE_BRIDGE_PARAMS_H_

#include <ros/ros.h>

#include <filesystem>
#include <string>

#include "absl/status/statusor.h"
#include "skimap/v1/frames.pb.h"

namespace skimap::rosbridge {

struct BridgeParams {
  std::string server = "127.0.0.1:50051";
  std::string token_file, tls_ca, tls_cert, tls_key;  // client/channel.h
  std::string map = "ros";                            // map id; created when missing
  double resolution = 0.05;                           // metres, for a map the bridge creates
  bool recognition = false;                           // recognition on a map the bridge creates
  std::string fixed_frame = "map";                    // poses, grids and markers are in this frame
  std::string camera_frame;                           // "" = the depth image's header.frame_id
  double tf_wait = 0.1;                               // seconds to wait for a frame's transform
  bool compressed_color = false;
  bool compressed_depth = false;        // depth/image/compressedDepth instead of depth/image
  bool use_color = true;                // false: depth/image + depth/camera_info only
  int sync_queue = 10;                  // message_filters queue per topic
  std::string depth_encoding = "zstd";  // zstd | rvl | png16 | raw
  int window = 8;                       // frames in flight to skimapd
  int queue_frames = 2;                 // frames waiting to be sent; more are dropped
  double publish_rate = 1.0;            // Hz; 0 = never
  double inflation_radius = 0;          // metres, the grid's obstacle inflation
  bool keep_seen_through = false;       // the grid keeps obstacles later views saw through
  bool publish_height_map = true;
  std::string save_dir;    // ~save_map writes under it; "" = the service is off
  std::string stats_file;  // at exit: counters and latencies as JSON
  // Seconds the node may take to release skimapd's stream once its report is written
  // (after SIGINT / SIGTERM); a skimapd that stopped reading holds gRPC's blocking write,
  // and the node then exits with status 2 instead of waiting for it.
  double shutdown_timeout = 5.0;
};

// Reads the private parameters; InvalidArgument naming the parameter for a bad value.
absl::StatusOr<BridgeParams> ReadParams(const ros::NodeHandle& private_nh);

// ~depth_encoding's value as the API's encoding; InvalidArgument naming the parameter.
absl::StatusOr<v1::DepthEncoding> ParseDepthEncoding(const std::string& name);

// ~save_map's `path` (client-named) under `root` (~save_dir), or InvalidArgument naming
// `path`: it must be relative and must not climb out with "..".
absl::StatusOr<std::filesystem::path> SavePath(const std::string& root, const std::string& name);

}  // namespace skimap::rosbridge

#endif  // ROS_BRIDGE_BRIDGE_PARAMS_H_
