#include "client/cli/eval_command.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_split.h"
#include "client/cli/dataset_frames.h"
#include "client/cli/instances_command.h"
#include "client/cli/stream_command.h"
#include "client/cli/view_stats.h"
#include "dataset/model_points.h"
#include "dataset/reader.h"
#include "nlohmann/json.hpp"

namespace skimap::client {
namespace {

namespace fs = std::filesystem;

double Ratio(int a, int b) { return b > 0 ? static_cast<double>(a) / b : 0; }

// Model points of every object with a model file, at most this many each (MSSD's cost is
// points x symmetries per pair; an even subset of a dense mesh gives the same maximum
// within a fraction of its vertex spacing).
constexpr int kMssdPoints = 1000;

absl::StatusOr<std::map<int, std::vector<Eigen::Vector3d>>> LoadAllModelPoints(
    const std::map<int, dataset::ModelInfo>& models) {
  std::map<int, std::vector<Eigen::Vector3d>> points;
  for (const auto& [obj_id, model] : models) {
    if (model.ply_path.empty()) continue;
    absl::StatusOr<std::vector<Eigen::Vector3d>> p =
        dataset::LoadModelPoints(model.ply_path, 0.001, kMssdPoints);
    if (!p.ok()) return p.status();
    points[obj_id] = *std::move(p);
  }
  return points;
}

// The test scenes to run: all, or the ones named (NotFound naming one the split lacks).
absl::StatusOr<std::vector<std::string>> PickScenes(const std::vector<std::string>& all,
                                                    const EvalOptions& options,
                                                    const std::string& dataset_root) {
  if (options.scenes.empty()) return all;
  std::vector<std::string> scenes;
  for (absl::string_view name : absl::StrSplit(options.scenes, ',')) {
    auto dir = std::find_if(all.begin(), all.end(), [&](const std::string& d) {
      return fs::path(d).filename().string() == name;
    });
    if (dir == all.end()) {
      return absl::NotFoundError(
          absl::StrCat("--scenes: ", name, " is not a test scene of ", dataset_root));
    }
    scenes.push_back(*dir);
  }
  return scenes;
}

// The scene's objects in the world frame, from its first annotated frame with a pose.
std::vector<TruthObject> SceneTruths(const dataset::Sequence& sequence) {
  std::vector<TruthObject> truths;
  for (const dataset::Frame& f : sequence.frames) {
    if (f.objects.empty() || !f.has_pose) continue;
    for (const dataset::ObjectAnnotation& a : f.objects) {
      truths.push_back({a.obj_id, f.T_wc * a.T_m2c});
    }
    break;
  }
  return truths;
}

// The single-view baseline's instances for these frames (those with a pose and colour).
absl::StatusOr<std::vector<v1::Instance>> SingleView(ObjectClient& objects,
                                                     const std::vector<dataset::Frame>& frames,
                                                     const SingleViewOptions& options) {
  SingleViewScene scene;
  for (const dataset::Frame& f : frames) {
    if (!f.has_pose || f.rgb_path.empty()) continue;
    absl::StatusOr<v1::ClassifyImageRequest> request = ToClassifyImageRequest(f);
    if (!request.ok()) return request.status();
    absl::StatusOr<v1::ClassifyImageResponse> response = objects.ClassifyImage(*request);
    if (!response.ok()) return response.status();
    scene.Add(EstimateSingleViewPoses(response->matches(), f.K, options), f.T_wc);
  }
  return scene.Instances();
}

// One method's score of one scene, added to its totals.
struct MethodScore {
  SceneScore score;
  MssdRecall mssd;
};

MethodScore ScoreMethod(const std::vector<TruthObject>& truths,
                        const std::vector<v1::Instance>& instances,
                        const dataset::BopDataset& dataset,
                        const std::map<int, std::vector<Eigen::Vector3d>>& points,
                        const ScoreOptions& options, MethodTotals* totals) {
  MethodScore s{ScoreScene(truths, instances, dataset.models, options), {}};
  AddMssdScene(truths, instances, dataset.models, points, &s.mssd);
  totals->instances += s.score.instances;
  totals->true_positives += s.score.true_positives;
  totals->mssd.truths += s.mssd.truths;
  for (int k = 0; k < MssdRecall::kThresholds; ++k) totals->mssd.matched[k] += s.mssd.matched[k];
  return s;
}

// "instances | true positives | precision | recall | AR_MSSD" cells of a table row.
std::string Cells(int truths, int instances, int true_positives, const MssdRecall& mssd,
                  bool mssd_available) {
  return absl::StrFormat("%d | %d | %.3f | %.3f | %s", instances, true_positives,
                         Ratio(true_positives, instances), Ratio(true_positives, truths),
                         mssd_available ? absl::StrFormat("%.3f", mssd.Average()) : "-");
}

constexpr char kNoCells[] = "- | - | - | - | -";

absl::Status WriteFile(const std::string& flag, const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::trunc);
  out << text;
  out.close();
  if (!out) return absl::UnavailableError(absl::StrCat("--", flag, ": cannot write ", path));
  return absl::OkStatus();
}

// One scene's instances of one method as summary entries: obj_id, score, and whether the
// instance is a true positive (matched to a truth).
void AddDetections(const std::string& scene, const std::vector<v1::Instance>& instances,
                   const SceneScore& score, nlohmann::ordered_json* out) {
  std::vector<bool> matched(instances.size(), false);
  for (int m : score.match) {
    if (m >= 0) matched[m] = true;
  }
  for (size_t i = 0; i < instances.size(); ++i) {
    out->push_back({{"scene", scene},
                    {"obj_id", instances[i].obj_id()},
                    {"score", instances[i].score()},
                    {"fit", instances[i].fit()},
                    {"view_conflict", instances[i].view_conflict()},
                    {"score_scale", instances[i].score_scale()},
                    {"true_positive", static_cast<bool>(matched[i])}});
  }
}

nlohmann::ordered_json MethodSummary(const MethodTotals& t, int truths, bool mssd_available) {
  return {{"instances", t.instances},
          {"true_positives", t.true_positives},
          {"precision", Ratio(t.true_positives, t.instances)},
          {"recall", Ratio(t.true_positives, truths)},
          {"ar_mssd", mssd_available ? nlohmann::ordered_json(t.mssd.Average()) : nullptr}};
}

}  // namespace

absl::StatusOr<EvalTotals> RunEval(MapClient& client, ObjectClient& objects,
                                   const std::string& dataset_root, const EvalOptions& options) {
  absl::StatusOr<dataset::BopDataset> dataset = dataset::LoadBopDataset(dataset_root);
  if (!dataset.ok()) return dataset.status();
  absl::StatusOr<std::vector<std::string>> scenes =
      PickScenes(dataset->scenes["test"], options, dataset_root);
  if (!scenes.ok()) return scenes.status();
  if (scenes->empty()) return absl::NotFoundError(absl::StrCat(dataset_root, ": no test/ scenes"));
  absl::StatusOr<std::map<int, std::vector<Eigen::Vector3d>>> model_points =
      LoadAllModelPoints(dataset->models);
  if (!model_points.ok()) return model_points.status();
  std::ofstream csv;
  if (!options.csv.empty()) {
    csv.open(options.csv, std::ios::trunc);
    if (!csv) return absl::UnavailableError(absl::StrCat("--csv: cannot write ", options.csv));
    csv << "scene,obj_id,instance_id,translation_error_mm,rotation_error_deg,true_positive,"
           "single_view_translation_error_mm,single_view_rotation_error_deg,"
           "single_view_true_positive\n";
  }
  if (!options.instances_dir.empty()) {
    std::error_code error;
    fs::create_directories(options.instances_dir, error);
    if (error) {
      return absl::UnavailableError(
          absl::StrCat("--instances_dir: cannot create ", options.instances_dir));
    }
  }
  std::printf(
      "| scene | frames | truths | instances | true positives | precision | recall | AR_MSSD | "
      "single-view instances | single-view true positives | single-view precision | "
      "single-view recall | single-view AR_MSSD | frames/s (whole pipeline) |\n"
      "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  EvalTotals totals;
  nlohmann::ordered_json detections = nlohmann::ordered_json::array();
  nlohmann::ordered_json single_detections = nlohmann::ordered_json::array();
  // Per obj_id: annotated, found by the map, found by the single view.
  std::map<int, std::array<int, 3>> per_object;
  ViewRecall view_recall;
  nlohmann::ordered_json truth_details = nlohmann::ordered_json::array();
  for (const std::string& dir : *scenes) {
    const std::string name = fs::path(dir).filename().string();
    absl::StatusOr<dataset::Sequence> sequence = dataset::LoadBopScene(dir);
    if (!sequence.ok()) return sequence.status();
    if (sequence->frames.empty()) continue;
    const std::vector<TruthObject> truths = SceneTruths(*sequence);
    // The frames the stream sends (every n-th, at most max_frames): the single view and the
    // view statistics take the same ones.
    const std::vector<dataset::Frame> streamed_frames =
        KeepEvery(sequence->frames, options.every, options.max_frames);
    bool mssd_available = true;
    for (const TruthObject& t : truths) mssd_available &= model_points->contains(t.obj_id);
    totals.mssd_available &= mssd_available;

    StreamOptions stream;
    stream.map_id = absl::StrCat("eval_", name);
    stream.resolution = options.resolution;
    stream.map_options = options.map_options;
    stream.quiet = true;
    stream.every = options.every;
    stream.max_frames = options.max_frames;
    stream.recognition.emplace();
    stream.recognition->set_enabled(true);
    stream.recognition->set_policy(v1::RecognitionOptions::EVERY_FRAME);
    if (options.min_instance_score) {
      stream.recognition->set_min_instance_score(*options.min_instance_score);
    }
    if (options.min_instance_fit) {
      stream.recognition->set_min_instance_fit(*options.min_instance_fit);
    }
    if (options.max_view_conflict) {
      stream.recognition->set_max_view_conflict(*options.max_view_conflict);
    }
    const std::string map = "maps/" + stream.map_id;
    if (absl::Status s = client.DeleteMap(map); !s.ok() && !absl::IsNotFound(s)) return s;
    const auto start = std::chrono::steady_clock::now();
    if (absl::Status s = StreamDataset(client, dir, stream); !s.ok()) return s;
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    absl::StatusOr<v1::Map> streamed = client.GetMap(map);
    if (!streamed.ok()) return streamed.status();
    const int frames = static_cast<int>(streamed->stats().frames());
    v1::ListInstancesRequest list;
    list.set_map(map);
    list.set_page_size(1000);
    absl::StatusOr<std::vector<v1::Instance>> instances = client.ListAllInstances(list);
    if (!instances.ok()) return instances.status();
    if (!options.keep_maps) {
      if (absl::Status s = client.DeleteMap(map); !s.ok()) return s;
    }
    const MethodScore multi =
        ScoreMethod(truths, *instances, *dataset, *model_points, options.score, &totals.multi_view);
    AddDetections(name, *instances, multi.score, &detections);

    std::vector<v1::Instance> single_instances;
    MethodScore single;
    if (options.single_view) {
      absl::StatusOr<std::vector<v1::Instance>> found =
          SingleView(objects, streamed_frames, options.single_view_options);
      if (!found.ok()) return found.status();
      single_instances = *std::move(found);
      single = ScoreMethod(truths, single_instances, *dataset, *model_points, options.score,
                           &totals.single_view);
      AddDetections(name, single_instances, single.score, &single_detections);
    }
    if (!options.instances_dir.empty()) {
      const fs::path base = fs::path(options.instances_dir) / name;
      if (absl::Status s = WriteFile("instances_dir", base.string() + ".json",
                                     FormatInstances(*instances, true));
          !s.ok()) {
        return s;
      }
      if (options.single_view) {
        if (absl::Status s = WriteFile("instances_dir", base.string() + ".single_view.json",
                                       FormatInstances(single_instances, true));
            !s.ok()) {
          return s;
        }
      }
    }
    const int n = static_cast<int>(truths.size());
    std::printf(
        "| %s | %d | %d | %s | %s | %.1f |\n", name.c_str(), frames, n,
        Cells(n, multi.score.instances, multi.score.true_positives, multi.mssd, mssd_available)
            .c_str(),
        options.single_view ? Cells(n, single.score.instances, single.score.true_positives,
                                    single.mssd, mssd_available)
                                  .c_str()
                            : kNoCells,
        seconds > 0 ? frames / seconds : 0);
    std::fflush(stdout);
    for (size_t t = 0; t < truths.size(); ++t) {
      std::array<int, 3>& o = per_object[truths[t].obj_id];
      ++o[0];
      const int m = multi.score.match[t];
      const int sv = options.single_view ? single.score.match[t] : -1;
      if (m >= 0) ++o[1];
      if (sv >= 0) ++o[2];
      if (!csv.is_open()) continue;
      csv << name << "," << truths[t].obj_id << ","
          << (m >= 0 ? absl::StrCat((*instances)[m].id()) : "") << ","
          << (m >= 0 ? absl::StrCat(multi.score.error[t].translation * 1000) : "") << ","
          << (m >= 0 ? absl::StrCat(multi.score.error[t].rotation_deg) : "") << "," << (m >= 0)
          << "," << (sv >= 0 ? absl::StrCat(single.score.error[t].translation * 1000) : "") << ","
          << (sv >= 0 ? absl::StrCat(single.score.error[t].rotation_deg) : "") << "," << (sv >= 0)
          << "\n";
    }
    const std::vector<ViewStats> views =
        SceneViewStats(streamed_frames, n, options.max_view_distance);
    for (int t = 0; t < n; ++t) {
      const bool found = multi.score.match[t] >= 0;
      view_recall.Add(views[t], found);
      truth_details.push_back({{"scene", name},
                               {"obj_id", truths[t].obj_id},
                               {"frames_in_view", views[t].frames_in_view},
                               {"median_distance", views[t].median_distance},
                               {"min_distance", views[t].min_distance},
                               {"median_pixels", views[t].median_pixels},
                               {"found", found}});
    }
    totals.truths += n;
    totals.frames += frames;
    totals.seconds += seconds;
  }
  const int n = totals.truths;
  std::printf("| all | %d | %d | %s | %s | %.1f |\n\n", totals.frames, n,
              Cells(n, totals.multi_view.instances, totals.multi_view.true_positives,
                    totals.multi_view.mssd, totals.mssd_available)
                  .c_str(),
              options.single_view
                  ? Cells(n, totals.single_view.instances, totals.single_view.true_positives,
                          totals.single_view.mssd, totals.mssd_available)
                        .c_str()
                  : kNoCells,
              totals.seconds > 0 ? totals.frames / totals.seconds : 0);
  totals.seen = view_recall.Seen(options.min_view_frames);
  totals.seen_found = view_recall.SeenFound(options.min_view_frames);
  std::printf(
      "Seen (in view in >= %d frames within %.1f m): %d of %d truths; found %d, recall %.3f\n\n"
      "%s\n",
      options.min_view_frames, options.max_view_distance, totals.seen, n, totals.seen_found,
      Ratio(totals.seen_found, totals.seen), view_recall.Tables().c_str());
  std::printf(
      "| obj_id | annotated | found | recall | single-view found | single-view recall |\n"
      "|---|---|---|---|---|---|\n");
  for (const auto& [obj_id, o] : per_object) {
    std::printf("| %d | %d | %d | %.2f | %s | %s |\n", obj_id, o[0], o[1], Ratio(o[1], o[0]),
                options.single_view ? absl::StrCat(o[2]).c_str() : "-",
                options.single_view ? absl::StrFormat("%.2f", Ratio(o[2], o[0])).c_str() : "-");
  }
  if (!options.summary.empty()) {
    nlohmann::ordered_json summary = {
        {"scenes", scenes->size()},
        {"frames", totals.frames},
        {"truths", n},
        {"seconds", totals.seconds},
        {"frames_per_second", totals.seconds > 0 ? totals.frames / totals.seconds : 0},
        {"max_translation_mm", options.score.max_translation * 1000},
        {"max_rotation_deg", options.score.max_rotation_deg},
        {"multi_view", MethodSummary(totals.multi_view, n, totals.mssd_available)},
    };
    summary["multi_view"]["seen"] = {{"min_view_frames", options.min_view_frames},
                                     {"max_view_distance", options.max_view_distance},
                                     {"truths", totals.seen},
                                     {"found", totals.seen_found},
                                     {"recall", Ratio(totals.seen_found, totals.seen)}};
    summary["multi_view"]["detections"] = std::move(detections);
    summary["truths_detail"] = std::move(truth_details);
    if (options.single_view) {
      summary["single_view"] = MethodSummary(totals.single_view, n, totals.mssd_available);
      summary["single_view"]["detections"] = std::move(single_detections);
    }
    if (absl::Status s = WriteFile("summary", options.summary, summary.dump(1) + "\n"); !s.ok()) {
      return s;
    }
  }
  return totals;
}

}  // namespace skimap::client
