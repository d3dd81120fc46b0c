// skimap-model-views: a 3D model file's training views written as a BOP scene folder, in
// a process of its own. skimapd runs it for ObjectService.AddObjectModel so that a model
// file that crashes, loops or eats memory in the model reader takes down only this
// process; it limits itself (CPU seconds, address space) before it reads anything.
//
// Usage: skimap-model-views --model FILE --out SCENE_DIR --obj_id N [--units auto|m|mm]
//          [--camera fx,fy,cx,cy,width,height] [--distances D,...] [--azimuths N]
//          [--effects clutter,lighting,sensor|none (default clutter)] [--max_memory_mb N]
//          [--max_cpu_seconds N]
// Exit status: 0 written; 2 the model or an option is refused (one line on stderr, naming
// the file as given); 1 anything else.
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "sim/model_io.h"
#include "sim/training_views.h"

namespace {

using namespace skimap;

int Refuse(const absl::Status& s) {
  std::fprintf(stderr, "%s\n", std::string(s.message()).c_str());
  return s.code() == absl::StatusCode::kInternal || s.code() == absl::StatusCode::kUnknown ? 1 : 2;
}

absl::StatusOr<std::vector<double>> Numbers(const std::string& text, const std::string& flag) {
  std::vector<double> out;
  for (absl::string_view part : absl::StrSplit(text, ',', absl::SkipWhitespace())) {
    double v = 0;
    if (!absl::SimpleAtod(part, &v)) {
      return absl::InvalidArgumentError(absl::StrCat(flag, ": '", part, "' is not a number"));
    }
    out.push_back(v);
  }
  return out;
}

int Run(const std::map<std::string, std::string>& args) {
  auto get = [&](const std::string& key, const std::string& fallback) {
    auto it = args.find(key);
    return it == args.end() ? fallback : it->second;
  };
  double memory_mb = 0, cpu_seconds = 0;
  if (!absl::SimpleAtod(get("max_memory_mb", "4096"), &memory_mb) || memory_mb < 64 ||
      !absl::SimpleAtod(get("max_cpu_seconds", "600"), &cpu_seconds) || cpu_seconds < 1) {
    return Refuse(absl::InvalidArgumentError("--max_memory_mb >= 64, --max_cpu_seconds >= 1"));
  }
  if (absl::Status s = sim::LimitThisProcess(static_cast<int>(cpu_seconds),
                                             static_cast<uint64_t>(memory_mb * 1048576.0));
      !s.ok()) {
    return Refuse(s);
  }
  const std::string model = get("model", ""), out = get("out", "");
  int obj_id = 0, azimuths = 0;
  if (model.empty() || out.empty() || !absl::SimpleAtoi(get("obj_id", ""), &obj_id) || obj_id < 1 ||
      !absl::SimpleAtoi(get("azimuths", "36"), &azimuths) || azimuths < 1 || azimuths > 360) {
    return Refuse(absl::InvalidArgumentError(
        "usage: skimap-model-views --model FILE --out DIR --obj_id N [--azimuths 1..360]"));
  }
  absl::StatusOr<sim::ModelUnits> units = sim::ParseModelUnits(get("units", "auto"), "units");
  if (!units.ok()) return Refuse(units.status());
  dataset::Intrinsics K{525.0, 525.0, 319.5, 239.5, 640, 480};
  if (args.count("camera")) {
    absl::StatusOr<std::vector<double>> c = Numbers(get("camera", ""), "camera");
    if (!c.ok()) return Refuse(c.status());
    if (c->size() != 6 || !((*c)[0] > 0) || !((*c)[1] > 0) || (*c)[4] < 1 || (*c)[4] > 8192 ||
        (*c)[5] < 1 || (*c)[5] > 8192) {
      return Refuse(absl::InvalidArgumentError("camera: fx,fy,cx,cy,width,height"));
    }
    K = {(*c)[0], (*c)[1], (*c)[2], (*c)[3], static_cast<int>((*c)[4]), static_cast<int>((*c)[5])};
  }
  sim::TrainingViewOptions options;
  options.azimuths = azimuths;
  absl::StatusOr<std::vector<double>> distances = Numbers(get("distances", ""), "distances");
  if (!distances.ok()) return Refuse(distances.status());
  for (double d : *distances) {
    if (!(d > 0.05 && d < 100)) return Refuse(absl::InvalidArgumentError("distances: 0.05-100 m"));
    options.distances.push_back(static_cast<float>(d));
  }
  if (absl::Status s = sim::ParseViewEffects(get("effects", "clutter"), "effects", &options);
      !s.ok()) {
    return Refuse(s);
  }
  absl::StatusOr<sim::Mesh> mesh = sim::LoadModel(model, {.units = *units});
  if (!mesh.ok()) return Refuse(mesh.status());
  const std::vector<sim::TrainingView> views = sim::RenderTrainingViews(*mesh, K, options);
  if (views.empty()) {
    return Refuse(absl::FailedPreconditionError(absl::StrCat(
        model, ": no training view shows the model (are its units right? units: auto, m, mm)")));
  }
  if (absl::Status s = sim::WriteTrainingScene(views, K, obj_id, out); !s.ok()) return Refuse(s);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  std::map<std::string, std::string> args;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a.rfind("--", 0) != 0 || i + 1 == argc) {
      std::fprintf(stderr, "skimap-model-views: '%s': options are --name VALUE\n", a.c_str());
      return 2;
    }
    args[a.substr(2)] = argv[++i];
  }
  return Run(args);
}
