#include "perception/objects/features.h"

#include <algorithm>
#include <cctype>
#include <numeric>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include "absl/strings/str_cat.h"
#include "base/echo.h"

namespace skimap::objects {
namespace {

cv::Ptr<cv::Feature2D> MakeDetector(const std::string& name, int max_features) {
  if (name == "ORB") return cv::ORB::create(max_features);
  if (name == "SIFT") return cv::SIFT::create(max_features);
  if (name == "AKAZE") return cv::AKAZE::create();
  if (name == "BRISK") return cv::BRISK::create();
  return nullptr;
}

}  // namespace

absl::StatusOr<std::string> CanonicalDetectorName(const std::string& detector) {
  std::string upper = detector;
  for (char& c : upper) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  if (upper == "ORB" || upper == "SIFT" || upper == "AKAZE" || upper == "BRISK") return upper;
  return absl::InvalidArgumentError(absl::StrCat(
      "detector: unknown feature detector ", Echo(detector), " (want ORB, SIFT, AKAZE or BRISK)"));
}

absl::StatusOr<DescriptorLayout> DetectorLayout(const std::string& detector) {
  absl::StatusOr<std::string> name = CanonicalDetectorName(detector);
  if (!name.ok()) return name.status();
  if (*name == "ORB") return DescriptorLayout{DescriptorKind::kBinary, 256};
  if (*name == "BRISK") return DescriptorLayout{DescriptorKind::kBinary, 512};
  if (*name == "AKAZE") return DescriptorLayout{DescriptorKind::kBinary, 488};
  return DescriptorLayout{DescriptorKind::kFloat, 128};
}

absl::StatusOr<std::unique_ptr<FeatureExtractor>> FeatureExtractor::Create(
    const FeatureOptions& options) {
  absl::StatusOr<std::string> name = CanonicalDetectorName(options.detector);
  if (!name.ok()) return name.status();
  if (options.max_features < 1 || options.max_features > 100000) {
    return absl::InvalidArgumentError(
        absl::StrCat("max_features: ", options.max_features, " must be in 1..100000"));
  }
  absl::StatusOr<DescriptorLayout> layout = DetectorLayout(*name);
  if (!layout.ok()) return layout.status();
  cv::Ptr<cv::Feature2D> detector;
  try {
    detector = MakeDetector(*name, options.max_features);
  } catch (const cv::Exception& e) {
    return absl::InternalError(absl::StrCat("detector ", *name, ": ", e.what()));
  }
  return std::unique_ptr<FeatureExtractor>(
      new FeatureExtractor(*name, *layout, std::move(detector), options.max_features));
}

FeatureExtractor::FeatureExtractor(std::string name, DescriptorLayout layout,
                                   cv::Ptr<cv::Feature2D> detector, int max_features)
    : name_(std::move(name)),
      layout_(layout),
      detector_(std::move(detector)),
      max_features_(max_features) {}

FeatureExtractor::~FeatureExtractor() = default;

absl::StatusOr<Features> FeatureExtractor::Extract(const cv::Mat& image, const cv::Mat& mask) {
  if (image.empty() || image.depth() != CV_8U || (image.channels() != 3 && image.channels() != 1)) {
    return absl::InvalidArgumentError("image: must be a non-empty CV_8UC3 or CV_8UC1 image");
  }
  if (!mask.empty() && (mask.type() != CV_8UC1 || mask.size() != image.size())) {
    return absl::InvalidArgumentError(
        absl::StrCat("mask: must be CV_8UC1 of the image size ", image.cols, "x", image.rows));
  }
  cv::Mat gray;
  if (image.channels() == 3) {
    cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
  } else {
    gray = image;
  }
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat desc;
  try {
    detector_->detectAndCompute(gray, mask, keypoints, desc);
  } catch (const cv::Exception& e) {
    return absl::InternalError(absl::StrCat("detector ", name_, ": ", e.what()));
  }
  Features out;
  out.descriptors = DescriptorMatrix(layout_);
  if (keypoints.empty()) return out;
  const bool binary = layout_.binary();
  if (desc.rows != static_cast<int>(keypoints.size()) ||
      desc.type() != (binary ? CV_8UC1 : CV_32FC1) ||
      desc.cols != (binary ? layout_.dims / 8 : layout_.dims)) {
    return absl::InternalError(absl::StrCat("detector ", name_, ": unexpected descriptor matrix ",
                                            desc.rows, "x", desc.cols, " type ", desc.type()));
  }
  std::vector<int> order(keypoints.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](int a, int b) { return keypoints[a].response > keypoints[b].response; });
  if (static_cast<int>(order.size()) > max_features_) order.resize(max_features_);
  out.keypoints.reserve(order.size());
  out.descriptors.Reserve(order.size());
  for (int i : order) {
    out.keypoints.push_back(keypoints[i]);
    if (binary) {
      out.descriptors.AppendBits(desc.ptr<uint8_t>(i));
    } else {
      out.descriptors.AppendValues(desc.ptr<float>(i));
    }
  }
  return out;
}

}  // namespace skimap::objects
