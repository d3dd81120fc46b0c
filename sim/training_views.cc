// Orbits of training views around a model. See training_views.h for the contract.
#include "sim/training_views.h"

#include <algorithm>
#include <opencv2/imgproc.hpp>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "codec/image_files.h"
#include "dataset/writer.h"
#include "sim/depth_noise.h"
#include "sim/rasterizer.h"
#include "sim/scene.h"
#include "sim/trajectory.h"

namespace skimap::sim {
namespace {

cv::Scalar RandomColour(std::mt19937_64& rng) {
  return cv::Scalar(Uniform(rng, 0, 255), Uniform(rng, 0, 255), Uniform(rng, 0, 255));
}

cv::Point RandomPoint(cv::Size size, std::mt19937_64& rng) {
  return {static_cast<int>(Uniform(rng, 0, static_cast<float>(size.width))),
          static_cast<int>(Uniform(rng, 0, static_cast<float>(size.height)))};
}

absl::Status WritePng(const std::string& path, const cv::Mat& image) {
  if (!perception::WriteImageFile(path, image).ok()) {
    return absl::InternalError(absl::StrCat(path, ": cannot write"));
  }
  return absl::OkStatus();
}

}  // namespace

absl::Status ParseViewEffects(absl::string_view text, const std::string& field,
                              TrainingViewOptions* options) {
  options->clutter = options->lighting = options->sensor = false;
  for (absl::string_view e : absl::StrSplit(text, ',', absl::SkipWhitespace())) {
    if (e == "clutter") {
      options->clutter = true;
    } else if (e == "lighting") {
      options->lighting = true;
    } else if (e == "sensor") {
      options->sensor = true;
    } else if (e != "none") {
      return absl::InvalidArgumentError(absl::StrCat(
          field, ": '", e.substr(0, 40), "' is not one of clutter, lighting, sensor or none"));
    }
  }
  return absl::OkStatus();
}

absl::Status WriteTrainingScene(const std::vector<TrainingView>& views,
                                const dataset::Intrinsics& K, int obj_id,
                                const std::string& scene_dir) {
  dataset::BopSceneWriter writer(scene_dir);
  if (absl::Status s = writer.Create(); !s.ok()) return s;
  for (size_t i = 0; i < views.size(); ++i) {
    const TrainingView& v = views[i];
    const int id = static_cast<int>(i);
    dataset::Frame f;
    f.id = id;
    f.timestamp = id;
    f.K = K;
    f.depth_scale = 1.0;
    f.has_pose = true;
    f.T_wc = v.T_m2c.inverse();  // world = the model's frame
    dataset::ObjectAnnotation a;
    a.obj_id = obj_id;
    a.T_m2c = v.T_m2c;
    a.px_count_visib = a.px_count_all = cv::countNonZero(v.mask);
    a.px_count_valid = cv::countNonZero(v.mask & (v.depth_mm > 0));
    a.visib_fract = 1;
    const cv::Rect box = cv::boundingRect(v.mask);
    a.bbox_visib = a.bbox_obj = {box.x, box.y, box.width, box.height};
    f.objects.push_back(a);
    if (absl::Status s = WritePng(dataset::BopRgbPath(scene_dir, id), v.bgr); !s.ok()) return s;
    if (absl::Status s = WritePng(dataset::BopDepthPath(scene_dir, id), v.depth_mm); !s.ok()) {
      return s;
    }
    if (absl::Status s = WritePng(dataset::BopMaskVisibPath(scene_dir, id, 0), v.mask); !s.ok()) {
      return s;
    }
    writer.AddFrame(f);
  }
  return writer.Finish();
}

cv::Mat ClutterBackground(cv::Size size, std::mt19937_64& rng) {
  cv::Mat bg(size, CV_8UC3, RandomColour(rng));
  const float scale = static_cast<float>(std::max(size.width, size.height));
  // Blotchy texture: coarse noise blown up, in two random colours.
  cv::Mat coarse(std::max(2, size.height / 24), std::max(2, size.width / 24), CV_8UC1);
  for (int v = 0; v < coarse.rows; ++v) {
    for (int u = 0; u < coarse.cols; ++u) {
      coarse.at<uint8_t>(v, u) = static_cast<uint8_t>(rng() >> 56);
    }
  }
  cv::Mat weight;
  cv::resize(coarse, weight, size, 0, 0, cv::INTER_CUBIC);
  const cv::Scalar a = RandomColour(rng), b = RandomColour(rng);
  for (int v = 0; v < size.height; ++v) {
    cv::Vec3b* row = bg.ptr<cv::Vec3b>(v);
    const uint8_t* w = weight.ptr<uint8_t>(v);
    for (int u = 0; u < size.width; ++u) {
      const float t = w[u] / 255.f;
      for (int c = 0; c < 3; ++c) row[u][c] = cv::saturate_cast<uint8_t>(a[c] * t + b[c] * (1 - t));
    }
  }
  // Shapes of every size: the edges and corners a room's furniture and posters give.
  const int shapes = 40 + static_cast<int>(rng() % 40);
  for (int i = 0; i < shapes; ++i) {
    const cv::Point p = RandomPoint(size, rng);
    const float extent = scale * std::pow(Uniform(rng, 0.1f, 1.f), 2.f) * 0.3f;
    const cv::Scalar colour = RandomColour(rng);
    switch (rng() % 4) {
      case 0: {
        const cv::Point q(p.x + static_cast<int>(Uniform(rng, -1, 1) * extent),
                          p.y + static_cast<int>(Uniform(rng, -1, 1) * extent));
        cv::rectangle(bg, p, q, colour, cv::FILLED, cv::LINE_AA);
        break;
      }
      case 1:
        cv::ellipse(bg, p,
                    cv::Size(std::max(1, static_cast<int>(extent * Uniform(rng, 0.2f, 1))),
                             std::max(1, static_cast<int>(extent * Uniform(rng, 0.2f, 1)))),
                    Uniform(rng, 0, 180), 0, 360, colour, cv::FILLED, cv::LINE_AA);
        break;
      case 2:
        cv::line(bg, p, RandomPoint(size, rng), colour, 1 + static_cast<int>(rng() % 6),
                 cv::LINE_AA);
        break;
      default: {
        std::vector<cv::Point> poly;
        for (int k = 0; k < 3 + static_cast<int>(rng() % 4); ++k) {
          poly.emplace_back(p.x + static_cast<int>(Uniform(rng, -1, 1) * extent),
                            p.y + static_cast<int>(Uniform(rng, -1, 1) * extent));
        }
        cv::fillPoly(bg, std::vector<std::vector<cv::Point>>{poly}, colour, cv::LINE_AA);
      }
    }
  }
  cv::GaussianBlur(bg, bg, {3, 3}, 0);  // a real lens never gives a one-pixel step
  return bg;
}

std::vector<TrainingView> RenderTrainingViews(const Mesh& mesh, const dataset::Intrinsics& K,
                                              const TrainingViewOptions& options) {
  const Eigen::Vector3f centre = mesh.Bounds().center();
  std::vector<float> distances = options.distances;
  if (distances.empty()) distances = {std::max(0.6f, 2.8f * mesh.Diameter())};
  // Without `lighting`: light from above and a little behind the first views, as a
  // room's ceiling lights.
  Lighting fixed_light;
  fixed_light.dir_world = Eigen::Vector3f(0.3f, 0.2f, -1.f).normalized();
  const Instance model{&mesh, Eigen::Isometry3f::Identity(), 1, /*two_sided=*/true};
  std::vector<TrainingView> views;
  RenderOutput out;
  uint64_t index = 0;
  for (float distance : distances) {
    for (float elevation : options.elevations_deg) {
      for (const Eigen::Isometry3f& T_wc :
           MakeTrainingOrbit(centre, distance, elevation, 0.f, std::max(1, options.azimuths))) {
        std::mt19937_64 rng(options.seed * 0x9E3779B97F4A7C15ull + 7919 * ++index);
        const Lighting light = options.lighting ? RandomLighting(rng) : fixed_light;
        Render({model}, K, T_wc, light, &out, 0.01f);
        TrainingView v;
        v.mask = out.ids == 1;
        if (cv::countNonZero(v.mask) == 0) continue;
        if (options.clutter) {
          v.bgr = ClutterBackground(out.bgr.size(), rng);
          out.bgr.copyTo(v.bgr, v.mask);
        } else {
          v.bgr = out.bgr.clone();
        }
        if (options.sensor) {
          AddColourNoise(v.bgr, 2.f, rng);
          v.depth_mm = SimulateDepth(out.depth, out.incidence, static_cast<float>(K.fx), 1.0,
                                     DepthNoise{}, rng);
        } else {
          out.depth.convertTo(v.depth_mm, CV_16UC1, 1000.0);
        }
        v.T_m2c = T_wc.inverse().cast<double>();
        views.push_back(std::move(v));
      }
    }
  }
  return views;
}

}  // namespace skimap::sim
