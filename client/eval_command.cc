#include "client/eval_command.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "client/stream_command.h"
#include "dataset/reader.h"

namespace skimap::client {
namespace {

double Ratio(int a, int b) { return b > 0 ? static_cast<double>(a) / b : 0; }

}  // namespace

absl::StatusOr<EvalTotals> RunEval(MapClient& client, const std::string& dataset_root,
                                   const EvalOptions& options) {
  absl::StatusOr<dataset::BopDataset> dataset = dataset::LoadBopDataset(dataset_root);
  if (!dataset.ok()) return dataset.status();
  const std::vector<std::string>& all = dataset->scenes["test"];
  std::vector<std::string> scenes;
  if (options.scenes.empty()) {
    scenes = all;
  } else {
    for (absl::string_view name : absl::StrSplit(options.scenes, ',')) {
      auto dir = std::find_if(all.begin(), all.end(), [&](const std::string& d) {
        return std::filesystem::path(d).filename().string() == name;
      });
      if (dir == all.end()) {
        return absl::NotFoundError(
            absl::StrCat("--scenes: ", name, " is not a test scene of ", dataset_root));
      }
      scenes.push_back(*dir);
    }
  }
  if (scenes.empty()) {
    return absl::NotFoundError(absl::StrCat(dataset_root, ": no test/ scenes"));
  }
  std::ofstream csv;
  if (!options.csv.empty()) {
    csv.open(options.csv, std::ios::trunc);
    if (!csv) return absl::UnavailableError(absl::StrCat("--csv: cannot write ", options.csv));
    csv << "scene,obj_id,instance_id,translation_error_mm,rotation_error_deg,true_positive\n";
  }
  std::printf(
      "| scene | frames | truths | instances | true positives | precision | recall | "
      "frames/s (whole pipeline) |\n|---|---|---|---|---|---|---|---|\n");
  EvalTotals totals;
  std::map<int, std::pair<int, int>> per_object;
  for (const std::string& dir : scenes) {
    const std::string name = std::filesystem::path(dir).filename().string();
    absl::StatusOr<dataset::Sequence> sequence = dataset::LoadBopScene(dir);
    if (!sequence.ok()) return sequence.status();
    if (sequence->frames.empty()) continue;
    // The scene's objects in the world frame, from its first annotated frame.
    std::vector<TruthObject> truths;
    for (const dataset::Frame& f : sequence->frames) {
      if (f.objects.empty() || !f.has_pose) continue;
      for (const dataset::ObjectAnnotation& a : f.objects) {
        truths.push_back({a.obj_id, f.T_wc * a.T_m2c});
      }
      break;
    }
    StreamOptions stream;
    stream.map_id = absl::StrCat("eval_", name);
    stream.resolution = options.resolution;
    stream.quiet = true;
    stream.every = options.every;
    stream.max_frames = options.max_frames;
    stream.recognition.emplace();
    stream.recognition->set_enabled(true);
    stream.recognition->set_policy(v1::RecognitionOptions::EVERY_FRAME);
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
    const SceneScore score = ScoreScene(truths, *instances, dataset->models, options.score);
    if (!options.keep_maps) {
      if (absl::Status s = client.DeleteMap(map); !s.ok()) return s;
    }
    std::printf("| %s | %d | %d | %d | %d | %.3f | %.3f | %.1f |\n", name.c_str(), frames,
                score.truths, score.instances, score.true_positives,
                Ratio(score.true_positives, score.instances),
                Ratio(score.true_positives, score.truths), seconds > 0 ? frames / seconds : 0);
    std::fflush(stdout);
    for (size_t t = 0; t < truths.size(); ++t) {
      if (!csv.is_open()) break;
      const int m = score.match[t];
      csv << name << "," << truths[t].obj_id << ","
          << (m >= 0 ? absl::StrCat((*instances)[m].id()) : "") << ","
          << (m >= 0 ? absl::StrCat(score.error[t].translation * 1000) : "") << ","
          << (m >= 0 ? absl::StrCat(score.error[t].rotation_deg) : "") << "," << (m >= 0) << "\n";
    }
    for (const auto& [obj_id, counts] : score.per_object) {
      per_object[obj_id].first += counts.first;
      per_object[obj_id].second += counts.second;
    }
    totals.truths += score.truths;
    totals.instances += score.instances;
    totals.true_positives += score.true_positives;
    totals.frames += frames;
    totals.seconds += seconds;
  }
  std::printf("| all | %d | %d | %d | %d | %.3f | %.3f | %.1f |\n\n", totals.frames, totals.truths,
              totals.instances, totals.true_positives,
              Ratio(totals.true_positives, totals.instances),
              Ratio(totals.true_positives, totals.truths),
              totals.seconds > 0 ? totals.frames / totals.seconds : 0);
  std::printf("| obj_id | found | annotated | recall |\n|---|---|---|---|\n");
  for (const auto& [obj_id, counts] : per_object) {
    std::printf("| %d | %d | %d | %.2f |\n", obj_id, counts.first, counts.second,
                Ratio(counts.first, counts.second));
  }
  return totals;
}

}  // namespace skimap::client
