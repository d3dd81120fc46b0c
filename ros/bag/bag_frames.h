// A bag as a sequence of frames (ros_frames.h): depth images paired with the colour image
// nearest in stamp, the camera's intrinsics from its camera_info, and its pose from tf.
//
// Two passes over the bag: the first reads /tf, /tf_static and the camera_info topic (into a
// tf2::BufferCore holding the whole recording), the second the images, so a transform
// recorded just after its image still poses it. A depth image with no colour image within
// sync_tolerance is sent without colour only when the bag has no colour topic; otherwise it
// is skipped and counted, as is one whose pose tf cannot give at its stamp (before the
// first transform, a gap in the tree). Each frame takes the last camera_info (with another
// K, size or distortion than the one before) stamped at or before it, frames before the
// first take the first; a bag without camera_info is refused. Frames of a camera_info with
// distortion are undistorted (rectify.h).
//
// Topics, when not given: the one depth topic, an Image whose name says depth or an
// image_transport compressedDepth CompressedImage ("<raw>/compressedDepth",
// compressed_depth.h; one that does not decode fails its frame only), preferring
// "registered" / "aligned" ones, then a raw image over its "/compressedDepth" twin; the one
// Image or CompressedImage topic whose name does not say depth (preferring a raw image
// over its /compressed twin, and names saying color or rgb); the
// CameraInfo beside the depth topic, else beside the colour topic, else the only one. More
// than one candidate left: InvalidArgument listing them and the flag to choose with.
//
// This header includes no ROS header (ROS 1's need C++17; the CLI including this is C++20).
//
// Thread safety: one call at a time per BagFrames.
#ifndef ROS_BAG_BAG_FRAMES_H_
#define ROS_BAG_BAG_FRAMES_H_

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "skimap/v1/frames.pb.h"

namespace skimap::bag {

// A frame made from messages (ros_frames.h): everything but the depth bytes in `frame`
// (timestamp from the depth header, pose, intrinsics, depth_scale 0.001, colour), and the
// depth as millimetres (0 = no measurement) for the caller to encode
// (client/frame_depth.h), so the wire encoding stays the client's choice.
struct RosFrame {
  v1::Frame frame;
  std::vector<uint16_t> depth_mm;  // width * height, row-major
  int width = 0, height = 0;
};

struct BagFrameOptions {
  std::string depth_topic;        // "" = chosen from the bag's topics (above)
  std::string color_topic;        // "" = chosen; "-" = no colour
  std::string camera_info_topic;  // "" = chosen
  // The frame poses are given in; "" = the root of the camera frame's tf tree.
  std::string fixed_frame;
  std::string camera_frame;      // "" = the depth image's header.frame_id
  double sync_tolerance = 0.02;  // seconds between a depth image and its colour image
  int every = 1;                 // keep every n-th frame (after pairing)
  int max_frames = 0;            // 0 = all
};

// The topics and frames a read settled on, and what it skipped.
struct BagFrameStats {
  std::string depth_topic, color_topic, camera_info_topic, fixed_frame;
  uint64_t depth_images = 0;  // on the depth topic
  uint64_t frames = 0;        // handed to the callback (made or failed)
  uint64_t without_color = 0;
  uint64_t without_pose = 0;
  std::string first_pose_error;  // tf's message for the first frame without a pose
};

class BagReader;

class BagFrames {
 public:
  // Opens the bag (bag_reader.h: NotFound, InvalidArgument, DataLoss) and chooses its
  // topics (InvalidArgument as above); messages start with the path.
  static absl::StatusOr<std::unique_ptr<BagFrames>> Open(const std::string& path,
                                                         const BagFrameOptions& options);
  ~BagFrames();

  // The topics chosen (the counters are still 0).
  const BagFrameStats& chosen() const { return chosen_; }
  // Depth images on the depth topic, when the bag's index says; 0 if not known.
  uint64_t depth_images() const { return depth_images_; }

  // Reads the bag and calls `fn` with each frame or the error that one frame could not be
  // made with (an image not matching its data, an unsupported encoding: the read goes on).
  // Stops at the bag's first problem (bag_reader.h) or the first non-OK status of `fn`,
  // returned as is. `stats` (optional) is filled as the read goes. Once per BagFrames.
  absl::Status Read(const std::function<absl::Status(absl::StatusOr<RosFrame>)>& fn,
                    BagFrameStats* stats = nullptr);

 private:
  BagFrames(std::unique_ptr<BagReader> bag, const BagFrameOptions& options);
  std::unique_ptr<BagReader> bag_;
  const BagFrameOptions options_;
  BagFrameStats chosen_;
  uint64_t depth_images_ = 0;
};

// Reads every message of the four frame types in the bag at `path` (OpenBag, ForEach) and
// drops it: the check `skimap stream` runs in a child process before reading a ROS 1 bag
// itself (client/cli/bag_frame_source.h). The first error, or OK.
absl::Status ReadAllFrameMessages(const std::string& path);

}  // namespace skimap::bag

#endif  // ROS_BAG_BAG_FRAMES_H_
