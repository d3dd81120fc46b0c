// Image files and bytes in tests, with cv::imread / cv::imwrite's shape over
// codec/image_files.h (the test programs do not link OpenCV's imgcodecs: see there): an
// empty matrix, or false, when the image cannot be read or written.
//
//   const cv::Mat depth = ImRead(path, ImageMode::kAnyDepth);
//   ASSERT_TRUE(ImWrite(dir + "/a.png", bgr));
//
// Thread safety: free functions; safe from any thread.
#ifndef TESTS_COMMON_IMAGES_H_
#define TESTS_COMMON_IMAGES_H_

#include <opencv2/core.hpp>
#include <string>
#include <string_view>
#include <vector>

#include "codec/image_files.h"

namespace skimap::testing {

using perception::ImageMode;

inline cv::Mat ImRead(const std::string& path, ImageMode mode = ImageMode::kColor) {
  return perception::ReadImageFile(path, mode).value_or(cv::Mat());
}

inline cv::Mat ImDecode(std::string_view bytes, ImageMode mode = ImageMode::kColor) {
  return perception::DecodeImage(bytes, mode).value_or(cv::Mat());
}

inline bool ImWrite(const std::string& path, const cv::Mat& image,
                    const perception::ImageEncoding& encoding = {}) {
  return perception::WriteImageFile(path, image, encoding).ok();
}

// The encoded bytes, appended to nothing: *out holds exactly them on success.
template <typename Bytes>
bool ImEncode(std::string_view extension, const cv::Mat& image, Bytes* out,
              const perception::ImageEncoding& encoding = {}) {
  absl::StatusOr<std::string> bytes = perception::EncodeImage(extension, image, encoding);
  if (!bytes.ok()) return false;
  out->assign(bytes->begin(), bytes->end());
  return true;
}

}  // namespace skimap::testing

#endif  // TESTS_COMMON_IMAGES_H_
