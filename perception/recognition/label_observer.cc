#include "perception/recognition/label_observer.h"

#include <cmath>

#include "opencv2/core.hpp"
#include "opencv2/imgproc.hpp"

namespace skimap::recognition {

LabelObserver::LabelObserver(const RecognitionModel& model) : model_(model) {
  absl::StatusOr<std::unique_ptr<objects::FeatureExtractor>> e =
      objects::FeatureExtractor::Create(model.db().params().features);
  if (e.ok()) extractor_ = *std::move(e);  // the database validated these options
}

LabelObserver::~LabelObserver() = default;

absl::StatusOr<LabelObservations> LabelObserver::Observe(const perception::RgbdFrame& frame,
                                                         double min_depth, double max_depth) {
  LabelObservations out;
  if (!frame.color.has_value() || extractor_ == nullptr) return out;
  const perception::ColorImage& color = *frame.color;
  cv::Mat gray;
  cv::cvtColor(cv::Mat(color.height, color.width, CV_8UC3, const_cast<uint8_t*>(color.rgb.data())),
               gray, cv::COLOR_RGB2GRAY);
  absl::StatusOr<objects::Features> features = extractor_->Extract(gray);
  if (!features.ok()) return features.status();
  out.features = static_cast<int>(features->keypoints.size());
  const perception::PinholeCamera& cam = frame.camera;
  const objects::ObjectDatabase& db = model_.db();
  // The keypoints with a depth in range, classified in one batch.
  std::vector<Eigen::Vector3f> points;
  objects::DescriptorMatrix kept(db.layout());
  for (size_t i = 0; i < features->keypoints.size(); ++i) {
    const cv::Point2f& pt = features->keypoints[i].pt;
    const int u = static_cast<int>(std::lround(pt.x)), v = static_cast<int>(std::lround(pt.y));
    if (u < 0 || v < 0 || u >= frame.depth.width || v >= frame.depth.height) continue;
    const uint16_t raw = frame.depth.pixels[static_cast<size_t>(v) * frame.depth.width + u];
    const double z = raw * frame.depth_scale;
    if (raw == 0 || z < min_depth || z > max_depth) continue;
    points.emplace_back(float((u - cam.cx) * z / cam.fx), float((v - cam.cy) * z / cam.fy),
                        float(z));
    kept.Append(features->descriptors.Row(i));
  }
  out.with_depth = static_cast<int>(points.size());
  db.ClassifyMany(kept, &predictions_);
  for (size_t i = 0; i < points.size(); ++i) {
    for (const objects::Prediction& p : predictions_[i]) {  // most confident first
      if (!p.verified) continue;
      // The most confident verified candidate decides; another object's feature is not
      // given to a wanted one.
      if (model_.object(p.object_index).wanted) {
        out.labels.push_back({points[i], p.cls, p.confidence});
      }
      break;
    }
  }
  out.verified = static_cast<int>(out.labels.size());
  return out;
}

void AddLabels(const LabelObservations& observations, const perception::CameraPose& pose,
               const Grid& grid, VoxelBatch<MultiLabelVoxel>* batch) {
  const Eigen::Matrix3d r = pose.rotation.toRotationMatrix();
  for (const LabelObservation& o : observations.labels) {
    const Eigen::Vector3d w = r * o.point.cast<double>() + pose.translation;
    VoxelKey key;
    if (!grid.ToKey({w.x(), w.y(), w.z()}, &key)) continue;
    batch->AddKey(key, MultiLabelVoxel(o.cls, 1));
  }
}

}  // namespace skimap::recognition
