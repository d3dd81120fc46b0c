#include "ros/bridge/bridge_params.h"

#include <cmath>

#include "absl/strings/str_cat.h"

namespace skimap::rosbridge {

absl::StatusOr<v1::DepthEncoding> ParseDepthEncoding(const std::string& name) {
  if (name == "zstd") return v1::DEPTH_ENCODING_ZSTD;
  if (name == "rvl") return v1::DEPTH_ENCODING_RVL;
  if (name == "png16") return v1::DEPTH_ENCODING_PNG16;
  if (name == "raw") return v1::DEPTH_ENCODING_RAW_U16;
  return absl::InvalidArgumentError(
      absl::StrCat("~depth_encoding: \"", name, "\" is not zstd, rvl, png16 or raw"));
}

absl::StatusOr<std::filesystem::path> SavePath(const std::string& root, const std::string& name) {
  namespace fs = std::filesystem;
  const fs::path relative(name);
  if (name.empty() || relative.is_absolute()) {
    return absl::InvalidArgumentError("path: must be a non-empty path relative to ~save_dir");
  }
  for (const fs::path& part : relative) {
    if (part == "..") return absl::InvalidArgumentError("path: must not contain ..");
  }
  return fs::weakly_canonical(fs::path(root)) / relative;
}

absl::StatusOr<BridgeParams> ReadParams(const ros::NodeHandle& pnh) {
  BridgeParams p;
  pnh.param("server", p.server, p.server);
  pnh.param("token_file", p.token_file, p.token_file);
  pnh.param("tls_ca", p.tls_ca, p.tls_ca);
  pnh.param("tls_cert", p.tls_cert, p.tls_cert);
  pnh.param("tls_key", p.tls_key, p.tls_key);
  pnh.param("map", p.map, p.map);
  pnh.param("resolution", p.resolution, p.resolution);
  pnh.param("recognition", p.recognition, p.recognition);
  pnh.param("fixed_frame", p.fixed_frame, p.fixed_frame);
  pnh.param("camera_frame", p.camera_frame, p.camera_frame);
  pnh.param("tf_wait", p.tf_wait, p.tf_wait);
  pnh.param("compressed_color", p.compressed_color, p.compressed_color);
  pnh.param("compressed_depth", p.compressed_depth, p.compressed_depth);
  pnh.param("use_color", p.use_color, p.use_color);
  pnh.param("sync_queue", p.sync_queue, p.sync_queue);
  pnh.param("depth_encoding", p.depth_encoding, p.depth_encoding);
  pnh.param("window", p.window, p.window);
  pnh.param("queue_frames", p.queue_frames, p.queue_frames);
  pnh.param("publish_rate", p.publish_rate, p.publish_rate);
  pnh.param("inflation_radius", p.inflation_radius, p.inflation_radius);
  pnh.param("keep_seen_through", p.keep_seen_through, p.keep_seen_through);
  pnh.param("publish_height_map", p.publish_height_map, p.publish_height_map);
  pnh.param("save_dir", p.save_dir, p.save_dir);
  pnh.param("stats_file", p.stats_file, p.stats_file);
  pnh.param("shutdown_timeout", p.shutdown_timeout, p.shutdown_timeout);
  const auto bad = [](const char* name, auto value, const char* rule) {
    return absl::InvalidArgumentError(absl::StrCat("~", name, ": ", value, " ", rule));
  };
  if (p.map.empty()) return absl::InvalidArgumentError("~map: must not be empty");
  if (p.fixed_frame.empty()) return absl::InvalidArgumentError("~fixed_frame: must not be empty");
  if (!(p.resolution > 0)) return bad("resolution", p.resolution, "must be > 0");
  if (!(p.tf_wait >= 0)) return bad("tf_wait", p.tf_wait, "must be >= 0");
  if (p.sync_queue < 1) return bad("sync_queue", p.sync_queue, "must be >= 1");
  if (p.window < 1) return bad("window", p.window, "must be >= 1");
  if (p.queue_frames < 1) return bad("queue_frames", p.queue_frames, "must be >= 1");
  if (!(p.publish_rate >= 0)) return bad("publish_rate", p.publish_rate, "must be >= 0");
  if (!(p.shutdown_timeout > 0) || !std::isfinite(p.shutdown_timeout))
    return bad("shutdown_timeout", p.shutdown_timeout, "must be a finite number > 0");
  if (!(p.inflation_radius >= 0))
    return bad("inflation_radius", p.inflation_radius, "must be >= 0");
  if (absl::StatusOr<v1::DepthEncoding> e = ParseDepthEncoding(p.depth_encoding); !e.ok()) {
    return e.status();
  }
  return p;
}

}  // namespace skimap::rosbridge
