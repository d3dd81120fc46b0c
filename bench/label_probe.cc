// label_probe: where robot-view recognition loses its objects, frame by frame. For every
// n-th frame of a BOP scene and every annotated object in view, it counts the detector's
// keypoints inside the object's visible mask, the labels the map would fuse there (the
// server's LabelObserver: forest + verification), and how many of those name the right
// object, then prints the means by distance (0.5 m bins). Diagnostic, not a benchmark
// with a peer: docs/recognition.md ("Robot view") quotes what it showed.
//
//   build/bench/bench/label_probe --db=DATA_DIR/objects.sqlite --scene=DATASET/test/000001
//       [--every=10] [--verify_threshold=D] [--upsampled_contrast=0.04]
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "absl/flags/flag.h"
#include "absl/flags/parse.h"
#include "bench/probe_frames.h"
#include "dataset/reader.h"
#include "opencv2/features2d.hpp"
#include "opencv2/imgproc.hpp"
#include "perception/objects/features.h"
#include "perception/recognition/label_observer.h"
#include "perception/recognition/recognition_model.h"
#include "server/core/objects/object_database_io.h"

ABSL_FLAG(std::string, db, "", "object database (a skimapd data dir's objects.sqlite)");
ABSL_FLAG(std::string, scene, "", "BOP scene folder");
ABSL_FLAG(int, every, 10, "probe every n-th frame");
ABSL_FLAG(double, verify_threshold, 0,
          "verify keypoints against their class's centroids at this distance instead of the "
          "database's (0: the database's)");
ABSL_FLAG(double, upsampled_contrast, 0.04,
          "SIFT contrast threshold of the last column: keypoints the image upsampled 2x "
          "would give (4000 at most; its detection time is printed; 0: not measured)");

namespace {

using namespace skimap;  // NOLINT: a small diagnostic program

[[noreturn]] void Die(const std::string& what) {
  std::fprintf(stderr, "label_probe: %s\n", what.c_str());
  std::exit(1);
}

struct Bin {
  int samples = 0;
  double pixels = 0, keypoints = 0, labels = 0, correct = 0, alt = 0, within2 = 0, within4 = 0;
};

}  // namespace

int main(int argc, char** argv) {
  absl::ParseCommandLine(argc, argv);
  absl::StatusOr<objects::ObjectDatabase> loaded =
      objects::LoadObjectDatabase(absl::GetFlag(FLAGS_db));
  if (!loaded.ok()) Die(loaded.status().ToString());
  if (const double t = absl::GetFlag(FLAGS_verify_threshold); t > 0) {
    objects::ObjectDatabaseParams params = loaded->params();
    params.verify_threshold = t;
    loaded = objects::ObjectDatabase::Create(params, loaded->objects(), loaded->forest());
    if (!loaded.ok()) Die(loaded.status().ToString());
  }
  auto db = std::make_shared<const objects::ObjectDatabase>(*std::move(loaded));
  absl::StatusOr<recognition::RecognitionModel> model =
      recognition::RecognitionModel::Create(db, {});
  if (!model.ok()) Die(model.status().ToString());
  recognition::LabelObserver observer(*model);
  absl::StatusOr<std::unique_ptr<objects::FeatureExtractor>> extractor =
      objects::FeatureExtractor::Create(db->params().features);
  if (!extractor.ok()) Die(extractor.status().ToString());
  absl::StatusOr<dataset::Sequence> seq = dataset::LoadBopScene(absl::GetFlag(FLAGS_scene));
  if (!seq.ok()) Die(seq.status().ToString());
  std::map<int, Bin> bins;  // by distance, 0.5 m
  int frames = 0;
  double all_keypoints = 0, observe_ms = 0, alt_ms = 0, alt_count = 0, all_labels = 0,
         labels_in_masks = 0, observed_keypoints = 0, with_depth = 0, labels_on_floor = 0;
  for (size_t i = 0; i < seq->frames.size(); i += absl::GetFlag(FLAGS_every)) {
    const dataset::Frame& f = seq->frames[i];
    absl::StatusOr<dataset::FrameImages> img = dataset::LoadFrameImages(f, true);
    if (!img.ok()) Die(img.status().ToString());
    // The observer sees the frame as the server decodes it; the masks and the detector's
    // own count need the images as stored (read a second time: a diagnostic).
    absl::StatusOr<perception::RgbdFrame> frame = bench::ProbeFrame(f);
    if (!frame.ok()) Die(frame.status().ToString());
    const auto t0 = std::chrono::steady_clock::now();
    absl::StatusOr<recognition::LabelObservations> obs = observer.Observe(*frame, 0.1, 5.0);
    const auto t1 = std::chrono::steady_clock::now();
    observe_ms += std::chrono::duration<double, std::milli>(t1 - t0).count();
    if (!obs.ok()) Die(obs.status().ToString());
    all_labels += obs->labels.size();
    observed_keypoints += obs->features;
    with_depth += obs->with_depth;
    // Labels on the floor (world z below 2 cm; the sim's floor is z = 0).
    const Eigen::Matrix3d r = frame->pose.rotation.toRotationMatrix();
    for (const recognition::LabelObservation& l : obs->labels) {
      labels_on_floor += (r * l.point.cast<double>() + frame->pose.translation).z() < 0.02;
    }
    absl::StatusOr<objects::Features> feats = (*extractor)->Extract(img->rgb);
    if (!feats.ok()) Die(feats.status().ToString());
    std::vector<cv::KeyPoint> alt;
    if (absl::GetFlag(FLAGS_upsampled_contrast) > 0) {
      cv::Mat up;
      cv::resize(img->rgb, up, {}, 2, 2, cv::INTER_LINEAR);
      cv::SIFT::create(4000, 3, absl::GetFlag(FLAGS_upsampled_contrast))->detect(up, alt);
      for (cv::KeyPoint& k : alt) k.pt = (k.pt - cv::Point2f(0.5f, 0.5f)) * 0.5f;
      alt_ms +=
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t1).count();
      alt_count += alt.size();
    }
    ++frames;
    all_keypoints += feats->keypoints.size();
    for (size_t g = 0; g < f.objects.size(); ++g) {
      const dataset::ObjectAnnotation& a = f.objects[g];
      const cv::Mat& mask = img->masks[g];
      if (a.px_count_visib < 100 || mask.empty()) continue;
      Bin& b = bins[static_cast<int>(a.T_m2c.translation().norm() / 0.5)];
      ++b.samples;
      b.pixels += a.px_count_visib;
      for (const cv::KeyPoint& k : feats->keypoints) {
        const int u = std::lround(k.pt.x), v = std::lround(k.pt.y);
        if (u >= 0 && v >= 0 && u < mask.cols && v < mask.rows && mask.at<uint8_t>(v, u)) {
          ++b.keypoints;
        }
      }
      for (const cv::KeyPoint& k : alt) {
        const int u = std::lround(k.pt.x), v = std::lround(k.pt.y);
        if (u >= 0 && v >= 0 && u < mask.cols && v < mask.rows && mask.at<uint8_t>(v, u)) ++b.alt;
      }
      for (const recognition::LabelObservation& l : obs->labels) {
        const int u = std::lround(f.K.fx * l.point.x() / l.point.z() + f.K.cx);
        const int v = std::lround(f.K.fy * l.point.y() / l.point.z() + f.K.cy);
        if (u < 0 || v < 0 || u >= mask.cols || v >= mask.rows || !mask.at<uint8_t>(v, u)) continue;
        ++b.labels;
        ++labels_in_masks;
        Eigen::Vector3f point;
        int object = -1;
        if (model->ClassPoint(l.cls, &point, &object) && model->object(object).obj_id == a.obj_id) {
          ++b.correct;
          const Eigen::Vector3d pm = a.T_m2c.inverse() * l.point.cast<double>();
          const double e = (pm - point.cast<double>()).norm();
          b.within2 += e < 0.02;
          b.within4 += e < 0.04;
        }
      }
    }
  }
  std::printf("%d frames, %.0f keypoints per frame (detector %s, max %d)\n", frames,
              all_keypoints / std::max(frames, 1), db->params().features.detector.c_str(),
              db->params().features.max_features);
  std::printf("Observe %.1f ms per frame; upsampled detection alone %.1f ms, %.0f keypoints\n",
              observe_ms / frames, alt_ms / frames, alt_count / frames);
  // Where the frame's labels lie: most on the background (floor, walls, tables).
  std::printf(
      "%.1f labels per frame, %.1f of them on an annotated object in view, %.1f on the "
      "floor (world z < 2 cm)\n",
      all_labels / std::max(frames, 1), labels_in_masks / std::max(frames, 1),
      labels_on_floor / std::max(frames, 1));
  std::printf("the observer: %.0f keypoints per frame, %.0f with a depth in range\n",
              observed_keypoints / std::max(frames, 1), with_depth / std::max(frames, 1));
  std::printf(
      "| distance (m) | object views | visible px | keypoints in mask | labels in mask | "
      "right object | ... within 2 cm of its class point | ... 4 cm | keypoints in mask, 2x "
      "upsampled |\n|---|---|---|---|---|---|---|---|---|\n");
  for (const auto& [k, b] : bins) {
    const double n = std::max(b.samples, 1);
    std::printf("| %.1f-%.1f | %d | %.0f | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f |\n", k * 0.5,
                k * 0.5 + 0.5, b.samples, b.pixels / n, b.keypoints / n, b.labels / n,
                b.correct / n, b.within2 / n, b.within4 / n, b.alt / n);
  }
  return 0;
}
