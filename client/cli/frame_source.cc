#include "client/cli/frame_source.h"

#include <filesystem>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "client/cli/dataset_frame_source.h"
#if SKIMAP_WITH_ROS
#include "client/cli/bag_frame_source.h"
#endif

namespace skimap::client {

bool IsBagPath(const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (fs::is_directory(path, ec)) return fs::exists(fs::path(path) / "metadata.yaml", ec);
  return absl::EndsWith(path, ".bag") || absl::EndsWith(path, ".mcap") ||
         absl::EndsWith(path, ".db3");
}

absl::StatusOr<std::unique_ptr<FrameSource>> OpenFrameSource(const std::string& path,
                                                             const FrameSourceOptions& options) {
  if (IsBagPath(path)) {
#if SKIMAP_WITH_ROS
    bag::BagFrameOptions bag;
    bag.depth_topic = options.bag.depth_topic;
    bag.color_topic = options.bag.color_topic;
    bag.camera_info_topic = options.bag.camera_info_topic;
    bag.fixed_frame = options.bag.fixed_frame;
    bag.camera_frame = options.bag.camera_frame;
    bag.sync_tolerance = options.bag.sync_tolerance;
    bag.every = options.every;
    bag.max_frames = options.max_frames;
    return OpenBagFrameSource(path, bag, options.depth_encoding, options.bag.check_seconds);
#else
    return absl::UnimplementedError(absl::StrCat(
        path, ": this skimap was built without ROS (scripts/deps.sh installs it): no bags"));
#endif
  }
  return DatasetFrameSource::Open(path, options);
}

}  // namespace skimap::client
