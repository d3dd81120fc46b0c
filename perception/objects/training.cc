#include "perception/objects/training.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "dataset/reader.h"

namespace skimap::objects {
namespace fs = std::filesystem;

absl::StatusOr<std::unique_ptr<ObjectDatabaseBuilder>> ObjectDatabaseBuilder::Create(
    const ObjectDatabaseParams& params) {
  absl::StatusOr<ObjectDatabaseParams> resolved = ResolveParams(params);
  if (!resolved.ok()) return resolved.status();
  return std::unique_ptr<ObjectDatabaseBuilder>(new ObjectDatabaseBuilder(*std::move(resolved)));
}

absl::Status ObjectDatabaseBuilder::AddObject(TrainedObject object) {
  for (const TrainedObject& o : objects_) {
    if (o.model.obj_id == object.model.obj_id) {
      return absl::AlreadyExistsError(absl::StrCat("obj_id: ", object.model.obj_id, " exists"));
    }
  }
  const DescriptorLayout layout = *DetectorLayout(params_.features.detector);
  if (object.raw.size() != object.model.voxels.size()) {
    return absl::InvalidArgumentError("object: raw descriptors do not match its voxels");
  }
  for (const DescriptorMatrix& m : object.raw) {
    if (!(m.layout() == layout)) {
      return absl::InvalidArgumentError(absl::StrCat("object ", object.model.obj_id,
                                                     ": descriptors were not made by ",
                                                     params_.features.detector));
    }
  }
  objects_.push_back(std::move(object));
  return absl::OkStatus();
}

absl::Status ObjectDatabaseBuilder::RemoveObject(int obj_id) {
  auto it = std::find_if(objects_.begin(), objects_.end(),
                         [&](const TrainedObject& o) { return o.model.obj_id == obj_id; });
  if (it == objects_.end())
    return absl::NotFoundError(absl::StrCat("obj_id: ", obj_id, " not found"));
  objects_.erase(it);
  return absl::OkStatus();
}

absl::StatusOr<ObjectDatabase> ObjectDatabaseBuilder::Build(const ProgressFn& progress) const {
  if (objects_.empty()) return absl::FailedPreconditionError("database: no objects to build");
  const int k = params_.classes_per_object;
  std::vector<int> voxels;
  for (const TrainedObject& o : objects_) voxels.push_back(static_cast<int>(o.model.voxels.size()));
  absl::StatusOr<ClassStack> stack = ClassStack::Create(k, voxels);
  if (!stack.ok()) return stack.status();

  const DescriptorLayout layout = *DetectorLayout(params_.features.detector);
  TrainingSet set{.dims = layout.FeatureDims()};
  std::vector<float> x(layout.FeatureDims());
  for (size_t o = 0; o < objects_.size(); ++o) {
    for (int j = 0; j < stack->used(static_cast<int>(o)); ++j) {
      const DescriptorMatrix& raw = objects_[o].raw[j];
      size_t n = raw.rows(), step = 1;
      if (params_.max_samples_per_class > 0 &&
          n > static_cast<size_t>(params_.max_samples_per_class)) {
        step = (n + params_.max_samples_per_class - 1) / params_.max_samples_per_class;
      }
      for (size_t i = 0; i < n; i += step) {
        ToFeatures(layout, raw.Row(i), x);
        set.Add(x, stack->ClassOf(static_cast<int>(o), j));
      }
    }
  }
  ForestOptions fo = params_.forest;
  absl::StatusOr<RandomForest> forest =
      RandomForest::Train(set, stack->num_classes(), fo, [&](int done, int total) {
        if (progress) progress({.stage = "forest", .done = done, .total = total});
      });
  if (!forest.ok()) return forest.status();
  std::vector<ObjectModel> models;
  for (const TrainedObject& o : objects_) models.push_back(o.model);
  return ObjectDatabase::Create(params_, std::move(models), *std::move(forest));
}

absl::StatusOr<TrainedObject> TrainObject(const std::string& scene_dir, int obj_id,
                                          std::string name, const ObjectDatabaseParams& params,
                                          const DatasetTrainingOptions& options) {
  absl::StatusOr<ObjectDatabaseParams> resolved = ResolveParams(params);
  if (!resolved.ok()) return resolved.status();
  if (options.threads < 1) {
    return absl::InvalidArgumentError(absl::StrCat("threads: ", options.threads, " must be >= 1"));
  }
  absl::StatusOr<dataset::Sequence> seq = dataset::LoadBopScene(scene_dir);
  if (!seq.ok()) return seq.status();
  absl::StatusOr<std::unique_ptr<ObjectTrainer>> trainer =
      ObjectTrainer::Create(obj_id, std::move(name), *resolved);
  if (!trainer.ok()) return trainer.status();
  const int64_t total = static_cast<int64_t>(seq->frames.size());
  int64_t done = 0;
  for (const dataset::Frame& frame : seq->frames) {
    ++done;
    if (options.use_frame && !options.use_frame(obj_id, frame.id)) continue;
    int which = -1;
    for (size_t i = 0; i < frame.objects.size(); ++i) {
      if (frame.objects[i].obj_id == obj_id) which = static_cast<int>(i);
    }
    if (which < 0 || frame.objects[which].mask_visib_path.empty()) continue;
    absl::StatusOr<dataset::FrameImages> img = dataset::LoadFrameImages(frame, true);
    if (!img.ok()) return img.status();
    if (cv::countNonZero(img->masks[which]) == 0) continue;  // fully occluded here
    TrainingFrame tf{.bgr = img->rgb,
                     .depth = img->depth,
                     .depth_scale = frame.depth_scale,
                     .K = frame.K,
                     .T_m2c = frame.objects[which].T_m2c,
                     .mask = img->masks[which]};
    absl::StatusOr<FrameContribution> c = (*trainer)->AddFrame(tf);
    if (!c.ok()) {
      return absl::Status(c.status().code(),
                          absl::StrCat(scene_dir, " frame ", frame.id, ": ", c.status().message()));
    }
    if (options.progress) options.progress({"frames", obj_id, done, total});
  }
  if (options.progress) options.progress({"mean_shift", obj_id, 0, 1});
  absl::StatusOr<TrainedObject> out = (*trainer)->Finish(options.threads);
  if (options.progress) options.progress({"mean_shift", obj_id, 1, 1});
  return out;
}

absl::StatusOr<std::vector<std::pair<int, std::string>>> ListTrainingObjects(
    const std::string& dataset_root) {
  const fs::path train = fs::path(dataset_root) / "train";
  std::error_code ec;
  if (!fs::is_directory(train, ec)) {
    return absl::NotFoundError(absl::StrCat("dataset: no train/ folder in ", dataset_root));
  }
  std::map<int, std::string> names;
  std::ifstream in(fs::path(dataset_root) / "objects.json");
  if (in) {
    nlohmann::json j = nlohmann::json::parse(in, nullptr, /*allow_exceptions=*/false);
    if (j.is_object()) {
      for (const auto& [key, value] : j.items()) {
        int id = 0;
        if (absl::SimpleAtoi(key, &id) && value.is_string()) names[id] = value.get<std::string>();
      }
    }
  }
  std::vector<std::pair<int, std::string>> out;
  for (const fs::directory_entry& e : fs::directory_iterator(train, ec)) {
    int id = 0;
    if (e.is_directory() && absl::SimpleAtoi(e.path().filename().string(), &id)) {
      out.emplace_back(id, names.count(id) ? names[id] : "");
    }
  }
  std::sort(out.begin(), out.end());
  return out;
}

absl::StatusOr<ObjectDatabase> TrainObjectDatabase(const std::string& dataset_root,
                                                   const ObjectDatabaseParams& params,
                                                   const DatasetTrainingOptions& options) {
  absl::StatusOr<std::unique_ptr<ObjectDatabaseBuilder>> builder =
      ObjectDatabaseBuilder::Create(params);
  if (!builder.ok()) return builder.status();
  absl::StatusOr<std::vector<std::pair<int, std::string>>> objects =
      ListTrainingObjects(dataset_root);
  if (!objects.ok()) return objects.status();
  for (const auto& [id, name] : *objects) {
    if (!options.obj_ids.empty() &&
        std::find(options.obj_ids.begin(), options.obj_ids.end(), id) == options.obj_ids.end()) {
      continue;
    }
    char folder[16];
    std::snprintf(folder, sizeof(folder), "%06d", id);
    absl::StatusOr<TrainedObject> t =
        TrainObject((fs::path(dataset_root) / "train" / folder).string(), id, name,
                    (*builder)->params(), options);
    if (!t.ok()) return t.status();
    if (absl::Status s = (*builder)->AddObject(*std::move(t)); !s.ok()) return s;
  }
  if ((*builder)->objects().empty()) {
    return absl::NotFoundError(absl::StrCat("dataset: no training objects in ", dataset_root));
  }
  return (*builder)->Build(options.progress);
}

}  // namespace skimap::objects
