#include "ros/bag/bag_frames.h"

#include <tf2/buffer_core.h>
#include <tf2/exceptions.h>

#include <boost/make_shared.hpp>
#include <cmath>
#include <deque>
#include <map>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "ros/bag/bag_reader.h"
#include "ros/bag/compressed_depth.h"
#include "ros/bag/rectify.h"
#include "ros/bag/ros_frames.h"

namespace skimap::bag {
namespace {

bool Says(const std::string& name, std::initializer_list<const char*> words) {
  const std::string lower = absl::AsciiStrToLower(name);
  for (const char* w : words) {
    if (absl::StrContains(lower, w)) return true;
  }
  return false;
}

// The folder of a topic: "/camera/depth/image_raw" -> "/camera/depth".
std::string Namespace(const std::string& topic) {
  const size_t slash = topic.rfind('/');
  return slash == std::string::npos ? "" : topic.substr(0, slash);
}

// Narrows `candidates` to those `prefer` accepts, when some are.
template <typename Pred>
std::vector<const BagTopic*> Prefer(std::vector<const BagTopic*> candidates, Pred prefer) {
  std::vector<const BagTopic*> kept;
  for (const BagTopic* t : candidates) {
    if (prefer(*t)) kept.push_back(t);
  }
  return kept.empty() ? candidates : kept;
}

absl::Status PickOne(const std::vector<const BagTopic*>& candidates, const char* what,
                     const char* flag, std::string* out) {
  if (candidates.size() == 1) {
    *out = candidates[0]->name;
    return absl::OkStatus();
  }
  std::vector<std::string> names;
  for (const BagTopic* t : candidates) names.push_back(t->name);
  if (names.empty()) {
    return absl::InvalidArgumentError(
        absl::StrCat("the bag has no ", what, " topic (", flag, " names one)"));
  }
  return absl::InvalidArgumentError(absl::StrCat("the bag has ", names.size(), " ", what,
                                                 " topics (", absl::StrJoin(names, ", "),
                                                 "): choose one with ", flag));
}

const BagTopic* Find(const std::vector<BagTopic>& topics, const std::string& name) {
  for (const BagTopic& t : topics) {
    if (t.name == name) return &t;
  }
  return nullptr;
}

absl::Status CheckGiven(const std::vector<BagTopic>& topics, const std::string& name,
                        std::initializer_list<const char*> types, const char* flag) {
  const BagTopic* t = Find(topics, name);
  if (t == nullptr) {
    return absl::InvalidArgumentError(absl::StrCat(flag, ": the bag has no topic ", name));
  }
  for (const char* type : types) {
    if (t->type == type) return absl::OkStatus();
  }
  return absl::InvalidArgumentError(
      absl::StrCat(flag, ": topic ", name, " is a ", t->type, ", not a ", *types.begin()));
}

Eigen::Isometry3d ToEigen(const geometry_msgs::Transform& t) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::Quaterniond(t.rotation.w, t.rotation.x, t.rotation.y, t.rotation.z)
                   .normalized()
                   .toRotationMatrix();
  T.translation() = Eigen::Vector3d(t.translation.x, t.translation.y, t.translation.z);
  return T;
}

struct Pending {
  ros::Time stamp;
  sensor_msgs::ImageConstPtr image;
  sensor_msgs::CompressedImageConstPtr compressed;
};

double Gap(const ros::Time& a, const ros::Time& b) { return std::fabs((a - b).toSec()); }

// The topics the options and the bag's topics select (or InvalidArgument: bag_frames.h).
absl::Status ChooseTopics(const std::vector<BagTopic>& topics, const BagFrameOptions& options,
                          BagFrameStats* chosen) {
  std::vector<const BagTopic*> depth, color, info;
  for (const BagTopic& t : topics) {
    // Depth: raw images, or image_transport's compressedDepth (compressed_depth.h), which
    // lives on "<raw topic>/compressedDepth".
    if ((t.type == kImageType && Says(t.name, {"depth"})) ||
        (t.type == kCompressedImageType && absl::EndsWith(t.name, "/compressedDepth"))) {
      depth.push_back(&t);
    }
    if ((t.type == kImageType || t.type == kCompressedImageType) && !Says(t.name, {"depth"})) {
      color.push_back(&t);
    }
    if (t.type == kCameraInfoType) info.push_back(&t);
  }
  if (!options.depth_topic.empty()) {
    if (absl::Status s = CheckGiven(topics, options.depth_topic, {kImageType, kCompressedImageType},
                                    "--depth_topic");
        !s.ok()) {
      return s;
    }
    chosen->depth_topic = options.depth_topic;
  } else {
    depth = Prefer(depth, [](const BagTopic& t) {
      return Says(t.name, {"registered", "aligned"});
    });
    // A raw depth image and its twin "<raw>/compressedDepth": the raw one.
    depth = Prefer(depth, [](const BagTopic& t) { return t.type == kImageType; });
    if (absl::Status s = PickOne(depth, "depth image", "--depth_topic", &chosen->depth_topic);
        !s.ok()) {
      return s;
    }
  }
  if (options.color_topic == "-") {
    chosen->color_topic.clear();
  } else if (!options.color_topic.empty()) {
    if (absl::Status s = CheckGiven(topics, options.color_topic, {kImageType, kCompressedImageType},
                                    "--color_topic");
        !s.ok()) {
      return s;
    }
    chosen->color_topic = options.color_topic;
  } else if (!color.empty()) {
    color = Prefer(color, [](const BagTopic& t) {
      return Says(t.name, {"color", "colour", "rgb"});
    });
    // A raw image and its image_transport twin "<raw>/compressed": the raw one.
    color = Prefer(color, [&](const BagTopic& t) {
      return Find(topics, t.name + "/compressed") != nullptr || t.type == kImageType;
    });
    if (absl::Status s =
            PickOne(color, "colour image", "--color_topic (- for none)", &chosen->color_topic);
        !s.ok()) {
      return s;
    }
  }
  if (!options.camera_info_topic.empty()) {
    if (absl::Status s =
            CheckGiven(topics, options.camera_info_topic, {kCameraInfoType}, "--camera_info_topic");
        !s.ok()) {
      return s;
    }
    chosen->camera_info_topic = options.camera_info_topic;
  } else {
    const auto beside = [&](const std::string& image_topic) -> const BagTopic* {
      if (image_topic.empty()) return nullptr;
      std::string ns = Namespace(image_topic);
      if (absl::EndsWith(image_topic, "/compressed") ||
          absl::EndsWith(image_topic, "/compressedDepth")) {
        ns = Namespace(ns);
      }
      const BagTopic* t = Find(topics, ns + "/camera_info");
      return t != nullptr && t->type == kCameraInfoType ? t : nullptr;
    };
    if (const BagTopic* t = beside(chosen->depth_topic)) {
      chosen->camera_info_topic = t->name;
    } else if (const BagTopic* t = beside(chosen->color_topic)) {
      chosen->camera_info_topic = t->name;
    } else if (absl::Status s =
                   PickOne(info, "camera_info", "--camera_info_topic", &chosen->camera_info_topic);
               !s.ok()) {
      return s;
    }
  }
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<std::unique_ptr<BagFrames>> BagFrames::Open(const std::string& path,
                                                           const BagFrameOptions& options) {
  absl::StatusOr<std::unique_ptr<BagReader>> bag = OpenBag(path);
  if (!bag.ok()) return bag.status();
  std::unique_ptr<BagFrames> frames(new BagFrames(*std::move(bag), options));
  if (absl::Status s = ChooseTopics(frames->bag_->topics(), options, &frames->chosen_); !s.ok()) {
    return absl::InvalidArgumentError(absl::StrCat(path, ": ", s.message()));
  }
  for (const BagTopic& t : frames->bag_->topics()) {
    if (t.name == frames->chosen_.depth_topic) frames->depth_images_ = t.count;
  }
  return frames;
}

BagFrames::BagFrames(std::unique_ptr<BagReader> bag, const BagFrameOptions& options)
    : bag_(std::move(bag)), options_(options) {}

BagFrames::~BagFrames() = default;

absl::Status BagFrames::Read(const std::function<absl::Status(absl::StatusOr<RosFrame>)>& fn,
                             BagFrameStats* stats_out) {
  BagReader& bag = *bag_;
  const BagFrameOptions& options = options_;
  BagFrameStats local;
  BagFrameStats& stats = stats_out != nullptr ? *stats_out : local;
  stats = chosen_;

  // Pass 1: tf and camera_info.
  std::vector<std::string> first_topics = {stats.camera_info_topic};
  for (const char* tf : {"/tf", "/tf_static"}) {
    const BagTopic* t = Find(bag.topics(), tf);
    if (t != nullptr && t->type == kTfType) first_topics.push_back(tf);
  }
  tf2::BufferCore buffer(ros::Duration(1e6));  // the whole recording
  std::map<std::string, std::string> parent;   // child frame -> parent frame, as last seen
  std::vector<std::pair<ros::Time, sensor_msgs::CameraInfoConstPtr>> infos;  // when K changes
  absl::Status s = bag.ForEach(first_topics, [&](const BagMessage& m) {
    if (m.info != nullptr) {
      if (infos.empty() || infos.back().second->K != m.info->K ||
          infos.back().second->width != m.info->width ||
          infos.back().second->height != m.info->height || infos.back().second->D != m.info->D ||
          infos.back().second->distortion_model != m.info->distortion_model) {
        infos.emplace_back(m.info->header.stamp, m.info);
      }
      return absl::OkStatus();
    }
    const bool is_static = *m.topic == "/tf_static";
    for (const geometry_msgs::TransformStamped& t : m.tf->transforms) {
      try {
        if (buffer.setTransform(t, "bag", is_static)) parent[t.child_frame_id] = t.header.frame_id;
      } catch (const std::exception&) {
        // tf2 refuses a transform it cannot use (NaN, frame named after itself): skipped.
      }
    }
    return absl::OkStatus();
  });
  if (!s.ok()) return s;
  if (infos.empty()) {
    return absl::InvalidArgumentError(
        absl::StrCat(stats.camera_info_topic, ": no camera_info message in the bag"));
  }

  // Pass 2: images, paired, posed, converted.
  std::vector<std::string> image_topics = {stats.depth_topic};
  if (!stats.color_topic.empty()) image_topics.push_back(stats.color_topic);
  std::deque<Pending> depths, colors;
  Rectifier rectifier;
  uint64_t paired = 0;
  bool enough = false;
  const auto emit = [&](const Pending& depth, const Pending* color) -> absl::Status {
    const uint64_t index = paired++;
    if (options.every > 1 && index % options.every != 0) return absl::OkStatus();
    if (options.max_frames > 0 && stats.frames >= uint64_t(options.max_frames)) {
      enough = true;
      return absl::OkStatus();
    }
    size_t i = infos.size();
    while (i > 1 && infos[i - 1].first > depth.stamp) --i;
    const sensor_msgs::CameraInfo& info = *infos[i - 1].second;
    // compressedDepth is decoded here, once the frame is kept, at the camera_info's size.
    sensor_msgs::ImageConstPtr depth_image = depth.image;
    if (depth_image == nullptr) {
      absl::StatusOr<sensor_msgs::Image> decoded =
          DecodeCompressedDepth(*depth.compressed, stats.depth_topic, info.width, info.height);
      if (!decoded.ok()) {
        ++stats.frames;
        return fn(decoded.status());
      }
      depth_image = boost::make_shared<const sensor_msgs::Image>(*std::move(decoded));
    }
    const std::string& camera =
        options.camera_frame.empty() ? depth_image->header.frame_id : options.camera_frame;
    if (stats.fixed_frame.empty()) {
      stats.fixed_frame = options.fixed_frame;
      if (stats.fixed_frame.empty()) {
        std::string root = camera;
        for (int hops = 0; hops < 1000 && parent.count(root); ++hops) root = parent[root];
        stats.fixed_frame = root;
      }
    }
    Eigen::Isometry3d T_wc;
    try {
      T_wc = ToEigen(buffer.lookupTransform(stats.fixed_frame, camera, depth.stamp).transform);
    } catch (const tf2::TransformException& e) {
      if (stats.without_pose++ == 0) stats.first_pose_error = e.what();
      return absl::OkStatus();
    }
    ColorMessage c;
    if (color != nullptr) {
      c.image = color->image.get();
      c.compressed = color->compressed.get();
      c.topic = stats.color_topic;
    }
    ++stats.frames;
    absl::StatusOr<RosFrame> frame =
        MakeRosFrame(*depth_image, stats.depth_topic, c, info, stats.camera_info_topic, T_wc);
    if (frame.ok()) {
      if (absl::Status r = rectifier.Rectify(info, stats.camera_info_topic, c.topic, &*frame);
          !r.ok()) {
        frame = r;
      }
    }
    return fn(std::move(frame));
  };
  // A colour image pairs with the depth image nearest in stamp within the tolerance; what
  // has waited a second of recording without a partner is dropped.
  const auto nearest = [&](std::deque<Pending>& queue, const ros::Time& stamp) {
    auto best = queue.end();
    for (auto it = queue.begin(); it != queue.end(); ++it) {
      if (Gap(it->stamp, stamp) <= options.sync_tolerance &&
          (best == queue.end() || Gap(it->stamp, stamp) < Gap(best->stamp, stamp))) {
        best = it;
      }
    }
    return best;
  };
  const auto prune = [&](const ros::Time& now) {
    while (!depths.empty() && (now - depths.front().stamp).toSec() > 1.0) {
      depths.pop_front();
      ++stats.without_color;
    }
    while (!colors.empty() && (now - colors.front().stamp).toSec() > 1.0) colors.pop_front();
  };
  s = bag.ForEach(image_topics, [&](const BagMessage& m) -> absl::Status {
    if (enough) return absl::CancelledError("enough frames");
    Pending p;
    if (*m.topic == stats.depth_topic) {
      ++stats.depth_images;
      p.image = m.image;
      p.compressed = m.compressed;
      p.stamp = m.image != nullptr ? m.image->header.stamp : m.compressed->header.stamp;
      if (stats.color_topic.empty()) return emit(p, nullptr);
      prune(p.stamp);
      auto c = nearest(colors, p.stamp);
      if (c == colors.end()) {
        depths.push_back(std::move(p));
        return absl::OkStatus();
      }
      const Pending color = *c;
      colors.erase(colors.begin(), c + 1);
      return emit(p, &color);
    }
    p.image = m.image;
    p.compressed = m.compressed;
    p.stamp = m.image != nullptr ? m.image->header.stamp : m.compressed->header.stamp;
    prune(p.stamp);
    auto d = nearest(depths, p.stamp);
    if (d == depths.end()) {
      colors.push_back(std::move(p));
      return absl::OkStatus();
    }
    stats.without_color += d - depths.begin();
    const Pending depth = *d;
    depths.erase(depths.begin(), d + 1);
    return emit(depth, &p);
  });
  if (enough) return absl::OkStatus();
  stats.without_color += depths.size();
  return s;
}

absl::Status ReadAllFrameMessages(const std::string& path) {
  absl::StatusOr<std::unique_ptr<BagReader>> reader = OpenBag(path);
  if (!reader.ok()) return reader.status();
  std::vector<std::string> topics;
  for (const BagTopic& t : (*reader)->topics()) {
    if (IsFrameType(t.type)) topics.push_back(t.name);
  }
  return (*reader)->ForEach(topics, [](const BagMessage&) { return absl::OkStatus(); });
}

}  // namespace skimap::bag
