// Detector-agnostic sparse 2D features: the detector / descriptor is a parameter, chosen
// by name (paper §3: "the adopted 2D feature detector-descriptor is just a parameter").
//
//   auto extractor = FeatureExtractor::Create({.detector = "ORB"});
//   absl::StatusOr<Features> f = (*extractor)->Extract(bgr, mask);
//
// Supported (OpenCV 4.6 main modules): ORB (256-bit binary), BRISK (512-bit binary),
// AKAZE (MLDB, 488-bit binary), SIFT (128 floats). Names are case-insensitive.
//
// Thread safety: a FeatureExtractor is not thread safe (OpenCV detectors keep state);
// use one per thread. The free functions are reentrant.
#ifndef SKIMAP_PERCEPTION_OBJECTS_FEATURES_H_
#define SKIMAP_PERCEPTION_OBJECTS_FEATURES_H_

#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "perception/objects/descriptors.h"

namespace cv {
class Feature2D;
}

namespace skimap::objects {

struct FeatureOptions {
  std::string detector = "SIFT";  // SIFT | ORB | AKAZE | BRISK
  int max_features = 1000;        // per image (the strongest responses are kept), 1..100000
  friend bool operator==(const FeatureOptions&, const FeatureOptions&) = default;
};

// Keypoints and their descriptors, row i describing keypoints[i].
struct Features {
  std::vector<cv::KeyPoint> keypoints;
  DescriptorMatrix descriptors;
};

// The descriptor layout a detector produces; InvalidArgument naming "detector" for an
// unknown name.
absl::StatusOr<DescriptorLayout> DetectorLayout(const std::string& detector);

// The canonical (upper-case) name of a detector, or InvalidArgument naming the field.
absl::StatusOr<std::string> CanonicalDetectorName(const std::string& detector);

class FeatureExtractor {
 public:
  // InvalidArgument naming the field for an unknown detector or max_features out of range.
  static absl::StatusOr<std::unique_ptr<FeatureExtractor>> Create(const FeatureOptions& options);
  ~FeatureExtractor();
  FeatureExtractor(const FeatureExtractor&) = delete;
  FeatureExtractor& operator=(const FeatureExtractor&) = delete;

  const std::string& name() const { return name_; }
  const DescriptorLayout& layout() const { return layout_; }

  // Detects and describes features in `image` (CV_8UC3 BGR or CV_8UC1), restricted to
  // `mask` (CV_8UC1, non-zero = allowed, same size) when mask is not empty. Keeps at most
  // max_features keypoints (strongest response first). InvalidArgument for a wrong image
  // or mask type/size.
  absl::StatusOr<Features> Extract(const cv::Mat& image, const cv::Mat& mask = cv::Mat());

 private:
  FeatureExtractor(std::string name, DescriptorLayout layout, cv::Ptr<cv::Feature2D> detector,
                   int max_features);

  std::string name_;
  DescriptorLayout layout_;
  cv::Ptr<cv::Feature2D> detector_;
  int max_features_;
};

}  // namespace skimap::objects

#endif  // SKIMAP_PERCEPTION_OBJECTS_FEATURES_H_
