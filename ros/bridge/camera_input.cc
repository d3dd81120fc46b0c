#include "ros/bridge/camera_input.h"

#include <message_filters/pass_through.h>
#include <message_filters/subscriber.h>
#include <message_filters/sync_policies/approximate_time.h>
#include <message_filters/synchronizer.h>
#include <sensor_msgs/CompressedImage.h>

#include <atomic>
#include <boost/bind/bind.hpp>
#include <boost/make_shared.hpp>

#include "ros/bag/compressed_depth.h"

namespace skimap::rosbridge {

using sensor_msgs::CameraInfo;
using sensor_msgs::CompressedImage;
using sensor_msgs::Image;

class CameraInput::Impl {
 public:
  Impl(ros::NodeHandle nh, const BridgeParams& params, FrameFn on_frame, BadFn on_bad)
      : nh_(nh), params_(params), on_frame_(std::move(on_frame)), on_bad_(std::move(on_bad)) {
    depth_topic_ =
        nh_.resolveName(params_.compressed_depth ? "depth/image/compressedDepth" : "depth/image");
    info_topic_ = nh_.resolveName(params_.use_color ? "rgb/camera_info" : "depth/camera_info");
    if (params_.use_color) {
      color_topic_ =
          nh_.resolveName(params_.compressed_color ? "rgb/image/compressed" : "rgb/image");
    }
  }

  void Start() {
    const int queue = params_.sync_queue;
    // Depth reaches the synchronisers through depth_in_: raw images as they come, or
    // compressedDepth decoded first. The synchronisers are connected before any input is
    // subscribed, so no message arrives half-wired.
    using boost::placeholders::_1, boost::placeholders::_2, boost::placeholders::_3;
    if (!params_.use_color) {
      depth_only_sync_ =
          std::make_unique<DepthOnlySync>(DepthOnlyPolicy(queue), depth_in_, info_sub_);
      depth_only_sync_->registerCallback(boost::bind(&Impl::OnDepthOnly, this, _1, _2));
    } else if (params_.compressed_color) {
      compressed_sync_ = std::make_unique<CompressedSync>(CompressedPolicy(queue), depth_in_,
                                                          compressed_sub_, info_sub_);
      compressed_sync_->registerCallback(boost::bind(&Impl::OnCompressed, this, _1, _2, _3));
    } else {
      sync_ = std::make_unique<RawSync>(RawPolicy(queue), depth_in_, color_sub_, info_sub_);
      sync_->registerCallback(boost::bind(&Impl::OnRaw, this, _1, _2, _3));
    }
    if (params_.compressed_depth) {
      // The camera's size as its camera_info last said: compressedDepth is decoded at it.
      info_sub_.registerCallback(boost::bind(&Impl::OnInfo, this, _1));
      compressed_depth_sub_ = nh_.subscribe(depth_topic_, queue, &Impl::OnCompressedDepth, this);
    } else {
      depth_in_.connectInput(depth_sub_);
      depth_sub_.subscribe(nh_, depth_topic_, queue);
    }
    info_sub_.subscribe(nh_, info_topic_, queue);
    if (params_.use_color && params_.compressed_color) {
      compressed_sub_.subscribe(nh_, color_topic_, queue);
    } else if (params_.use_color) {
      color_sub_.subscribe(nh_, color_topic_, queue);
    }
  }

  std::string depth_topic_, color_topic_, info_topic_;

 private:
  using RawPolicy = message_filters::sync_policies::ApproximateTime<Image, Image, CameraInfo>;
  using RawSync = message_filters::Synchronizer<RawPolicy>;
  using CompressedPolicy =
      message_filters::sync_policies::ApproximateTime<Image, CompressedImage, CameraInfo>;
  using CompressedSync = message_filters::Synchronizer<CompressedPolicy>;
  using DepthOnlyPolicy = message_filters::sync_policies::ApproximateTime<Image, CameraInfo>;
  using DepthOnlySync = message_filters::Synchronizer<DepthOnlyPolicy>;

  void OnInfo(const CameraInfo::ConstPtr& info) {
    info_size_.store(uint64_t{info->width} << 32 | info->height, std::memory_order_relaxed);
  }

  void OnCompressedDepth(const CompressedImage::ConstPtr& message) {
    // Before the first camera_info, any size up to the limit; then the camera_info's, so
    // that a message of a few bytes cannot claim a larger image.
    const uint64_t size = info_size_.load(std::memory_order_relaxed);
    absl::StatusOr<Image> depth = bag::DecodeCompressedDepth(
        *message, depth_topic_, uint32_t(size >> 32), uint32_t(size & 0xffffffffu));
    if (!depth.ok()) {
      on_bad_(depth.status());
      return;
    }
    depth_in_.add(boost::make_shared<const Image>(*std::move(depth)));
  }

  void OnDepthOnly(const Image::ConstPtr& depth, const CameraInfo::ConstPtr& info) {
    on_frame_(*depth, bag::ColorMessage(), *info);  // voxels get grey
  }

  void OnRaw(const Image::ConstPtr& depth, const Image::ConstPtr& image,
             const CameraInfo::ConstPtr& info) {
    bag::ColorMessage color;
    color.image = image.get();
    color.topic = color_topic_;
    on_frame_(*depth, color, *info);
  }

  void OnCompressed(const Image::ConstPtr& depth, const CompressedImage::ConstPtr& image,
                    const CameraInfo::ConstPtr& info) {
    bag::ColorMessage color;
    color.compressed = image.get();
    color.topic = color_topic_;
    on_frame_(*depth, color, *info);
  }

  ros::NodeHandle nh_;
  const BridgeParams params_;
  const FrameFn on_frame_;
  const BadFn on_bad_;
  std::atomic<uint64_t> info_size_{0};  // width << 32 | height of the last camera_info
  // Declared in the order that destroys the synchronisers first, then what feeds them, so
  // that nothing calls into a member already gone.
  message_filters::PassThrough<Image> depth_in_;
  message_filters::Subscriber<Image> depth_sub_, color_sub_;
  message_filters::Subscriber<CompressedImage> compressed_sub_;
  message_filters::Subscriber<CameraInfo> info_sub_;
  ros::Subscriber compressed_depth_sub_;
  std::unique_ptr<RawSync> sync_;
  std::unique_ptr<CompressedSync> compressed_sync_;
  std::unique_ptr<DepthOnlySync> depth_only_sync_;
};

CameraInput::CameraInput(ros::NodeHandle nh, const BridgeParams& params, FrameFn on_frame,
                         BadFn on_bad)
    : impl_(std::make_unique<Impl>(nh, params, std::move(on_frame), std::move(on_bad))) {}

CameraInput::~CameraInput() = default;

void CameraInput::Start() { impl_->Start(); }

const std::string& CameraInput::depth_topic() const { return impl_->depth_topic_; }
const std::string& CameraInput::info_topic() const { return impl_->info_topic_; }

}  // namespace skimap::rosbridge
