// LoadFrameImages and DepthToMeters. See reader.h for the contract.

#include "absl/strings/str_cat.h"
#include "codec/image_files.h"
#include "dataset/reader.h"

namespace skimap::dataset {
namespace {

absl::Status CheckSize(const cv::Mat& m, const Frame& f, const std::string& path) {
  if (f.K.width > 0 && (m.cols != f.K.width || m.rows != f.K.height)) {
    return absl::InvalidArgumentError(absl::StrCat(path, ": image is ", m.cols, "x", m.rows,
                                                   ", camera says ", f.K.width, "x", f.K.height));
  }
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<FrameImages> LoadFrameImages(const Frame& frame, bool load_masks) {
  FrameImages out;
  out.rgb =
      perception::ReadImageFile(frame.rgb_path, perception::ImageMode::kColor).value_or(cv::Mat());
  if (out.rgb.empty()) {
    return absl::NotFoundError(absl::StrCat(frame.rgb_path, ": cannot read rgb image"));
  }
  if (absl::Status s = CheckSize(out.rgb, frame, frame.rgb_path); !s.ok()) return s;
  if (!frame.depth_path.empty()) {
    out.depth = perception::ReadImageFile(frame.depth_path, perception::ImageMode::kUnchanged)
                    .value_or(cv::Mat());
    if (out.depth.empty()) {
      return absl::NotFoundError(absl::StrCat(frame.depth_path, ": cannot read depth image"));
    }
    if (out.depth.type() != CV_16UC1) {
      return absl::InvalidArgumentError(
          absl::StrCat(frame.depth_path, ": depth must be 16-bit single channel"));
    }
    if (absl::Status s = CheckSize(out.depth, frame, frame.depth_path); !s.ok()) return s;
  }
  if (load_masks) {
    out.masks.resize(frame.objects.size());
    for (size_t i = 0; i < frame.objects.size(); ++i) {
      const std::string& p = frame.objects[i].mask_visib_path;
      if (p.empty()) continue;
      out.masks[i] = perception::ReadImageFile(p, perception::ImageMode::kGrey).value_or(cv::Mat());
      if (out.masks[i].empty()) {
        return absl::NotFoundError(absl::StrCat(p, ": cannot read mask image"));
      }
      if (absl::Status s = CheckSize(out.masks[i], frame, p); !s.ok()) return s;
    }
  }
  return out;
}

cv::Mat DepthToMeters(const cv::Mat& raw_depth, double depth_scale) {
  cv::Mat m;
  raw_depth.convertTo(m, CV_32F, depth_scale * 1e-3);
  return m;
}

}  // namespace skimap::dataset
