#include "perception/objects/object_trainer.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <numeric>
#include <opencv2/imgproc.hpp>
#include <thread>

#include "absl/strings/str_cat.h"
#include "skimap/serialization.h"
#include "skimap/voxel_batch.h"

namespace skimap::objects {
namespace {

absl::Status CheckFrame(const TrainingFrame& f) {
  if (f.bgr.empty()) return absl::InvalidArgumentError("bgr: missing colour image");
  if (f.bgr.type() != CV_8UC3) return absl::InvalidArgumentError("bgr: must be CV_8UC3");
  if (f.depth.empty()) return absl::InvalidArgumentError("depth: missing depth image");
  if (f.depth.type() != CV_16UC1 && f.depth.type() != CV_32FC1) {
    return absl::InvalidArgumentError("depth: must be CV_16UC1 (raw) or CV_32FC1 (metres)");
  }
  if (f.depth.size() != f.bgr.size()) {
    return absl::InvalidArgumentError(absl::StrCat("depth: size ", f.depth.cols, "x", f.depth.rows,
                                                   " differs from bgr ", f.bgr.cols, "x",
                                                   f.bgr.rows));
  }
  if (f.mask.empty()) return absl::InvalidArgumentError("mask: missing object mask");
  if (f.mask.type() != CV_8UC1 || f.mask.size() != f.bgr.size()) {
    return absl::InvalidArgumentError("mask: must be CV_8UC1 of the image size");
  }
  if (cv::countNonZero(f.mask) == 0) {
    return absl::InvalidArgumentError("mask: empty (the object is not visible in this frame)");
  }
  if (!(f.K.fx > 0 && f.K.fy > 0 && std::isfinite(f.K.fx) && std::isfinite(f.K.fy) &&
        std::isfinite(f.K.cx) && std::isfinite(f.K.cy))) {
    return absl::InvalidArgumentError("K: fx and fy must be finite and > 0");
  }
  if (f.depth.type() == CV_16UC1 && !(f.depth_scale > 0 && std::isfinite(f.depth_scale))) {
    return absl::InvalidArgumentError(absl::StrCat("depth_scale: ", f.depth_scale, " must be > 0"));
  }
  if (!f.T_m2c.matrix().allFinite()) return absl::InvalidArgumentError("T_m2c: not finite");
  return absl::OkStatus();
}

// Depth in metres at pixel (u, v); 0 if none.
double DepthAt(const TrainingFrame& f, int u, int v) {
  if (f.depth.type() == CV_16UC1) return f.depth.at<uint16_t>(v, u) * f.depth_scale * 1e-3;
  const float z = f.depth.at<float>(v, u);
  return std::isfinite(z) && z > 0 ? z : 0.0;
}

}  // namespace

absl::StatusOr<std::unique_ptr<ObjectTrainer>> ObjectTrainer::Create(
    int obj_id, std::string name, const ObjectDatabaseParams& params) {
  absl::StatusOr<ObjectDatabaseParams> resolved = ResolveParams(params);
  if (!resolved.ok()) return resolved.status();
  if (!(*resolved == params)) {
    return absl::InvalidArgumentError("params: must be resolved (ResolveParams) first");
  }
  absl::StatusOr<std::unique_ptr<FeatureExtractor>> extractor =
      FeatureExtractor::Create(params.features);
  if (!extractor.ok()) return extractor.status();
  return std::unique_ptr<ObjectTrainer>(
      new ObjectTrainer(obj_id, std::move(name), params, *std::move(extractor)));
}

absl::Status ObjectTrainer::AddDescriptors(const TrainingFrame& f, const cv::Mat& mask,
                                           FrameContribution* out) {
  absl::StatusOr<Features> features = extractor_->Extract(f.bgr, mask);
  if (!features.ok()) return features.status();
  const Eigen::Isometry3d T_c2m = f.T_m2c.inverse();
  const Grid& grid = descriptors_->grid();
  const DescriptorLayout& layout = extractor_->layout();
  out->keypoints += static_cast<int>(features->keypoints.size());
  for (size_t i = 0; i < features->keypoints.size(); ++i) {
    const cv::Point2f& pt = features->keypoints[i].pt;
    const int u = static_cast<int>(std::lround(pt.x)), v = static_cast<int>(std::lround(pt.y));
    if (u < 0 || v < 0 || u >= f.depth.cols || v >= f.depth.rows) continue;
    const double z = DepthAt(f, u, v);
    if (z <= 0) continue;
    const Eigen::Vector3d pc((pt.x - f.K.cx) * z / f.K.fx, (pt.y - f.K.cy) * z / f.K.fy, z);
    const Eigen::Vector3d pm = T_c2m * pc;
    VoxelKey key;
    if (!grid.ToKey(pm.x(), pm.y(), pm.z(), &key)) continue;
    descriptors_->IntegrateKey(key, DescriptorVoxel::One(layout, features->descriptors.Row(i)));
    ++out->descriptors;
  }
  return absl::OkStatus();
}

ObjectTrainer::ObjectTrainer(int obj_id, std::string name, const ObjectDatabaseParams& params,
                             std::unique_ptr<FeatureExtractor> extractor)
    : obj_id_(obj_id),
      name_(std::move(name)),
      params_(params),
      extractor_(std::move(extractor)),
      descriptors_(std::make_unique<SkiMap<DescriptorVoxel>>(
          SkiMap<DescriptorVoxel>::Options{.resolution = params.resolution})),
      rgb_(std::make_unique<SkiMap<RGBWeightedVoxel>>(
          SkiMap<RGBWeightedVoxel>::Options{.resolution = params.resolution})) {}

absl::StatusOr<FrameContribution> ObjectTrainer::AddFrame(const TrainingFrame& f) {
  if (absl::Status s = CheckFrame(f); !s.ok()) return s;
  cv::Mat mask = f.mask;
  if (params_.mask_erosion_px > 0) {
    const int r = params_.mask_erosion_px;
    cv::erode(f.mask, mask, cv::getStructuringElement(cv::MORPH_ELLIPSE, {2 * r + 1, 2 * r + 1}));
  }
  FrameContribution out;
  if (absl::Status s = AddDescriptors(f, mask, &out); !s.ok()) return s;
  // Zoom-outs: the view shrunk by sqrt(2)^k (colour by area averaging, as a sensor's pixels
  // integrate a farther scene; mask and depth by nearest pixel, so no depth is invented).
  for (double s = std::sqrt(2.0); s <= params_.zoom_out + 1e-9; s *= std::sqrt(2.0)) {
    const cv::Size size(static_cast<int>(std::lround(f.bgr.cols / s)),
                        static_cast<int>(std::lround(f.bgr.rows / s)));
    if (size.width < 16 || size.height < 16) break;
    TrainingFrame z;
    cv::resize(f.bgr, z.bgr, size, 0, 0, cv::INTER_AREA);
    cv::resize(f.depth, z.depth, size, 0, 0, cv::INTER_NEAREST);
    cv::Mat zmask;
    cv::resize(mask, zmask, size, 0, 0, cv::INTER_NEAREST);
    if (cv::countNonZero(zmask) == 0) break;
    z.depth_scale = f.depth_scale;
    z.K = f.K;
    z.K.fx = f.K.fx / s, z.K.fy = f.K.fy / s;
    z.K.cx = (f.K.cx + 0.5) / s - 0.5, z.K.cy = (f.K.cy + 0.5) / s - 0.5;
    z.T_m2c = f.T_m2c;
    FrameContribution zoomed;
    if (absl::Status st = AddDescriptors(z, zmask, &zoomed); !st.ok()) return st;
    out.keypoints += zoomed.keypoints;
    out.descriptors += zoomed.descriptors;
  }

  const Eigen::Isometry3d T_c2m = f.T_m2c.inverse();
  VoxelBatch<RGBWeightedVoxel> batch;
  const int step = params_.rgb_stride_px;
  for (int v = 0; v < f.depth.rows; v += step) {
    const uint8_t* m = f.mask.ptr<uint8_t>(v);
    const cv::Vec3b* c = f.bgr.ptr<cv::Vec3b>(v);
    for (int u = 0; u < f.depth.cols; u += step) {
      if (m[u] == 0) continue;
      const double z = DepthAt(f, u, v);
      if (z <= 0) continue;
      const Eigen::Vector3d pm =
          T_c2m * Eigen::Vector3d((u - f.K.cx) * z / f.K.fx, (v - f.K.cy) * z / f.K.fy, z);
      batch.Add(rgb_->grid(), pm.x(), pm.y(), pm.z(),
                RGBWeightedVoxel(c[u][2], c[u][1], c[u][0], 1));
    }
  }
  batch.Finalize();
  rgb_->Integrate(batch);

  ++stats_.frames;
  stats_.features += out.keypoints;
  stats_.descriptors += out.descriptors;
  stats_.raw_descriptor_bytes +=
      static_cast<int64_t>(out.descriptors) * extractor_->layout().RowBytes();
  return out;
}

absl::StatusOr<TrainedObject> ObjectTrainer::Finish(int threads) const {
  if (descriptors_->empty()) {
    return absl::FailedPreconditionError(
        absl::StrCat("object ", obj_id_,
                     ": no descriptor was fused (no training frame with "
                     "features and depth on the object)"));
  }
  std::vector<VoxelModel> voxels;
  std::vector<DescriptorMatrix> raw;
  descriptors_->ForEach([&](const VoxelKey& k, const DescriptorVoxel& v) {
    VoxelModel m;
    m.key = k;
    m.evidence = static_cast<uint32_t>(v.descriptors().rows());
    voxels.push_back(std::move(m));
    raw.push_back(v.descriptors());
  });
  std::atomic<size_t> next{0};
  std::atomic<bool> failed{false};
  absl::Status error;
  auto work = [&] {
    for (size_t i = next++; i < voxels.size(); i = next++) {
      absl::StatusOr<Clusters> c = MeanShift(raw[i], params_.mean_shift);
      if (!c.ok()) {
        if (!failed.exchange(true)) error = c.status();
        return;
      }
      voxels[i].centroids = std::move(c->centroids);
      voxels[i].cardinalities = std::move(c->cardinalities);
    }
  };
  std::vector<std::thread> pool;
  for (int i = 1; i < threads; ++i) pool.emplace_back(work);
  work();
  for (std::thread& t : pool) t.join();
  if (failed) return error;

  // Evidence order (descending), ties by key: rank j = position.
  std::vector<size_t> order(voxels.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    return voxels[a].evidence != voxels[b].evidence ? voxels[a].evidence > voxels[b].evidence
                                                    : voxels[a].key < voxels[b].key;
  });
  TrainedObject out;
  out.model.obj_id = obj_id_;
  out.model.name = name_;
  out.model.stats = stats_;
  out.model.stats.centroid_bytes = 0;
  for (size_t i : order) {
    out.model.stats.centroid_bytes += static_cast<int64_t>(
        voxels[i].centroids.PayloadBytes() + voxels[i].cardinalities.size() * sizeof(uint32_t));
    out.model.voxels.push_back(std::move(voxels[i]));
    out.raw.push_back(std::move(raw[i]));
  }
  out.model.rgb_volume = SerializeMap(*rgb_);
  return out;
}

}  // namespace skimap::objects
