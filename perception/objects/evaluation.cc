#include "perception/objects/evaluation.h"

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <map>
#include <opencv2/imgproc.hpp>

#include "dataset/reader.h"

namespace skimap::objects {

absl::StatusOr<std::vector<ObjectAccuracy>> EvaluateViews(const ObjectDatabase& db,
                                                          const std::string& dataset_root,
                                                          const EvaluationOptions& options) {
  absl::StatusOr<std::unique_ptr<FeatureExtractor>> extractor =
      FeatureExtractor::Create(db.params().features);
  if (!extractor.ok()) return extractor.status();
  std::vector<ObjectAccuracy> out;
  std::vector<float> scratch;
  std::vector<Prediction> candidates;
  for (const ObjectModel& object : db.objects()) {
    ObjectAccuracy acc;
    acc.obj_id = object.obj_id;
    char folder[16];
    std::snprintf(folder, sizeof(folder), "%06d", object.obj_id);
    absl::StatusOr<dataset::Sequence> seq =
        dataset::LoadBopScene((std::filesystem::path(dataset_root) / "train" / folder).string());
    if (!seq.ok()) return seq.status();
    for (const dataset::Frame& frame : seq->frames) {
      if (options.use_frame && !options.use_frame(object.obj_id, frame.id)) continue;
      int which = -1;
      for (size_t i = 0; i < frame.objects.size(); ++i) {
        if (frame.objects[i].obj_id == object.obj_id) which = static_cast<int>(i);
      }
      if (which < 0) continue;
      absl::StatusOr<dataset::FrameImages> img = dataset::LoadFrameImages(frame, true);
      if (!img.ok()) return img.status();
      cv::Mat mask = img->masks[which];
      if (mask.empty() || cv::countNonZero(mask) == 0) continue;
      if (const int r = db.params().mask_erosion_px; r > 0) {
        cv::erode(mask, mask, cv::getStructuringElement(cv::MORPH_ELLIPSE, {2 * r + 1, 2 * r + 1}));
      }
      absl::StatusOr<Features> f = (*extractor)->Extract(img->rgb, mask);
      if (!f.ok()) return f.status();
      std::map<int, double> votes;
      const auto t0 = std::chrono::steady_clock::now();
      for (size_t i = 0; i < f->descriptors.rows(); ++i) {
        db.Classify(f->descriptors.Row(i), &scratch, &candidates);
        ++acc.features;
        if (!candidates.empty() && candidates[0].obj_id == object.obj_id) ++acc.top1;
        for (const Prediction& p : candidates) {
          if (!p.verified) continue;
          ++acc.verified;
          if (p.obj_id == object.obj_id) ++acc.correct;
          votes[p.obj_id] += p.confidence;
          break;
        }
      }
      acc.predict_seconds +=
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      ++acc.views;
      int best = 0;
      double best_votes = 0;
      for (const auto& [id, v] : votes) {
        if (v > best_votes) {
          best_votes = v;
          best = id;
        }
      }
      if (best == object.obj_id) ++acc.views_correct;
    }
    out.push_back(acc);
  }
  return out;
}

ObjectAccuracy Total(const std::vector<ObjectAccuracy>& per_object) {
  ObjectAccuracy t;
  for (const ObjectAccuracy& a : per_object) {
    t.features += a.features;
    t.top1 += a.top1;
    t.verified += a.verified;
    t.correct += a.correct;
    t.views += a.views;
    t.views_correct += a.views_correct;
    t.predict_seconds += a.predict_seconds;
  }
  return t;
}

}  // namespace skimap::objects
