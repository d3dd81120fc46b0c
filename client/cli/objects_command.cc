#include "client/cli/objects_command.h"

#include <cstdio>
#include <filesystem>

#include "absl/flags/flag.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "absl/time/clock.h"
#include "client/cli/model_files.h"
#include "client/cli/model_views.h"
#include "client/cli/training_frames.h"
#include "client/object_client.h"
#include "dataset/reader.h"
#include "sim/training_views.h"

ABSL_FLAG(int, object, 0, "objects train: train only this obj_id (0 = every train/ object)");
ABSL_FLAG(std::string, detector, "", "objects train: SIFT, ORB, AKAZE or BRISK (default SIFT)");
ABSL_FLAG(std::string, name, "", "objects train: display name (default: objects.json)");
ABSL_FLAG(int, frame_stride, 1, "objects train: use every n-th training frame");
ABSL_FLAG(double, object_resolution, 0, "objects train: descriptor voxel in metres (0 = 0.01)");
ABSL_FLAG(double, zoom_out, 0,
          "objects train: synthetic zoom-outs up to this factor (1 = off; 0 = the server's "
          "default)");
ABSL_FLAG(bool, on_server, false,
          "objects train: the server reads DATASET from its disk; objects add: the model and "
          "the files it names are uploaded and the server renders the views");
ABSL_FLAG(std::string, model_units, "auto",
          "objects add: the model's units: m, mm (BOP models) or auto (mm when its bounding "
          "box's diagonal exceeds 10)");
ABSL_FLAG(std::string, camera, "",
          "objects add: BOP camera.json whose intrinsics the training views use (default a "
          "Kinect: 525 px focal length, 640x480)");
ABSL_FLAG(std::string, view_distances, "",
          "objects add: comma list of camera distances in metres (default max(0.6, 2.8 x "
          "the model's diameter), as the sim's training orbits)");
ABSL_FLAG(int, view_azimuths, 36,
          "objects add: views per orbit (evenly spaced azimuths; 3 orbits, at 10, 35 and 60 "
          "degrees)");
ABSL_FLAG(std::string, view_effects, "clutter",
          "objects add: what a camera adds to the rendered views, a comma list of clutter (a "
          "random background), lighting (a random light per view) and sensor (colour noise, "
          "Kinect depth noise); none: perfect renders on black; default: clutter, the best on the "
          "validation render (docs/recognition.md)");
ABSL_FLAG(int, classes_per_object, 0, "objects build: k voxels per object (0 = stored/300)");
ABSL_FLAG(int, trees, 0, "objects build: forest trees (0 = stored/24)");
ABSL_FLAG(int, tree_depth, 0,
          "objects build: forest (tree) depth, ClassifierParams.max_depth (0 = stored/24)");
ABSL_FLAG(double, verify_threshold, 0,
          "objects build: descriptor distance a candidate voxel must be within to verify a "
          "feature (0 = stored; negative = the detector's default: SIFT 250, binary 0.3 x "
          "bits)");
ABSL_FLAG(int, top_n, 0, "objects build: candidate voxels verified per feature (0 = stored/3)");

namespace skimap::client {
namespace {
namespace fs = std::filesystem;

int Fail(const absl::Status& s) {
  std::fprintf(stderr, "skimap: %s\n", s.ToString().c_str());
  return 1;
}

int Exit(const absl::Status& s) { return s.ok() ? 0 : Fail(s); }

void PrintObject(const v1::Object& o) {
  std::printf("%-14s %-20s frames %4llu  descriptors %7llu  voxels %6llu  centroids %7llu  %s%s\n",
              o.name().c_str(), o.display_name().empty() ? "-" : o.display_name().c_str(),
              (unsigned long long)o.frames(), (unsigned long long)o.descriptors(),
              (unsigned long long)o.voxels(), (unsigned long long)o.centroids(),
              o.params().detector().c_str(), o.in_classifier() ? "  [classifier]" : "");
}

void PrintProgress(const v1::Operation& op) {
  std::fprintf(stderr, "\r%s: %-10s %lld/%lld  %3.0f%%  %.1f s   ", op.name().c_str(),
               op.progress().stage().c_str(), (long long)op.progress().done(),
               (long long)op.progress().total(), 100 * op.progress().fraction(),
               op.elapsed().seconds() + op.elapsed().nanos() * 1e-9);
  if (op.done()) std::fprintf(stderr, "\n");
}

v1::TrainingParams ParamsFromFlags() {
  v1::TrainingParams p;
  p.set_detector(absl::GetFlag(FLAGS_detector));
  if (absl::GetFlag(FLAGS_object_resolution) > 0) {
    p.set_resolution(absl::GetFlag(FLAGS_object_resolution));
  }
  if (absl::GetFlag(FLAGS_zoom_out) > 0) p.set_zoom_out(absl::GetFlag(FLAGS_zoom_out));
  return p;
}

absl::StatusOr<v1::Object> StreamObject(ObjectClient& client, const TrainingObject& object) {
  absl::StatusOr<dataset::Sequence> seq = dataset::LoadBopScene(object.scene_dir);
  if (!seq.ok()) return seq.status();
  v1::TrainObjectRequest header;
  header.set_obj_id(object.obj_id);
  header.set_display_name(object.name);
  *header.mutable_params() = ParamsFromFlags();
  const int stride = std::max(1, absl::GetFlag(FLAGS_frame_stride));
  size_t next = 0;
  int sent = 0;
  return client.TrainObject(header, [&]() -> absl::StatusOr<std::optional<v1::TrainingFrame>> {
    while (next < seq->frames.size()) {
      const dataset::Frame& f = seq->frames[next++];
      if (f.id % stride != 0) continue;
      absl::StatusOr<std::optional<v1::TrainingFrame>> frame = ToTrainingFrame(f, object.obj_id);
      if (!frame.ok() || !frame->has_value()) {
        if (!frame.ok()) return frame.status();
        continue;
      }
      std::fprintf(stderr, "\rtraining objects/%d: frame %d sent  ", object.obj_id, ++sent);
      return frame;
    }
    std::fprintf(stderr, "\rtraining objects/%d: %d frames sent, mean shift...\n", object.obj_id,
                 sent);
    return std::optional<v1::TrainingFrame>();
  });
}

// `objects add MODEL --on_server`: the model and the files it names are uploaded; the
// server renders the views (AddObjectModel) and trains.
absl::Status AddModelOnServer(ObjectClient& client, const std::string& model,
                              const ModelViewOptions& options) {
  absl::StatusOr<ModelFileSet> set = ModelFiles(model);
  if (!set.ok()) return set.status();
  for (const std::string& name : set->skipped) {
    std::fprintf(stderr, "warning: %s names %s, which is not a file in its folder: not sent\n",
                 model.c_str(), name.c_str());
  }
  v1::AddObjectModelRequest header;
  header.set_obj_id(static_cast<uint32_t>(absl::GetFlag(FLAGS_object)));
  header.set_display_name(absl::GetFlag(FLAGS_name));
  header.set_model(set->files[0].name);
  v1::ModelViews* views = header.mutable_views();
  views->set_units(options.units);
  views->set_azimuths(static_cast<uint32_t>(options.azimuths));
  for (float d : options.distances) views->add_distances(d);
  views->set_effects(absl::GetFlag(FLAGS_view_effects).empty() ? "none"
                                                               : absl::GetFlag(FLAGS_view_effects));
  if (!options.camera.empty()) {
    absl::StatusOr<dataset::CameraInfo> camera = dataset::LoadBopCamera(options.camera);
    if (!camera.ok()) return camera.status();
    v1::CameraIntrinsics* k = views->mutable_intrinsics();
    k->set_fx(camera->K.fx);
    k->set_fy(camera->K.fy);
    k->set_cx(camera->K.cx);
    k->set_cy(camera->K.cy);
    k->set_width(camera->K.width);
    k->set_height(camera->K.height);
  }
  *header.mutable_params() = ParamsFromFlags();
  std::fprintf(stderr, "uploading %zu file(s) of %s...\n", set->files.size(), model.c_str());
  absl::StatusOr<v1::Operation> op = client.AddObjectModel(header, set->files);
  if (!op.ok()) return op.status();
  op = client.WaitDone(op->name(), PrintProgress);
  if (!op.ok()) return op.status();
  PrintObject(op->object());
  return absl::OkStatus();
}

// `objects add MODEL --object=ID`: training views rendered from the model file, streamed
// as `objects train` streams a sequence's.
// The model is read and rendered before the client connects: sim::LoadModel forks, and
// gRPC's threads must not exist yet (model_io.h).
absl::Status AddModel(const std::string& server, const Connection& connection,
                      const std::string& model) {
  const int id = absl::GetFlag(FLAGS_object);
  if (id <= 0) return absl::InvalidArgumentError("objects add needs --object=ID (1..999999)");
  const int azimuths = absl::GetFlag(FLAGS_view_azimuths);
  if (azimuths < 1 || azimuths > 360) {
    return absl::InvalidArgumentError("--view_azimuths: 1..360 views per orbit");
  }
  ModelViewOptions options{
      absl::GetFlag(FLAGS_model_units), absl::GetFlag(FLAGS_camera), {}, azimuths};
  for (absl::string_view d :
       absl::StrSplit(absl::GetFlag(FLAGS_view_distances), ',', absl::SkipWhitespace())) {
    float metres = 0;
    if (!absl::SimpleAtof(d, &metres) || !(metres > 0.05f && metres < 100.f)) {
      return absl::InvalidArgumentError(
          absl::StrCat("--view_distances: '", d, "' is not a distance in metres (0.05-100)"));
    }
    options.distances.push_back(metres);
  }
  if (absl::Status st = sim::ParseViewEffects(absl::GetFlag(FLAGS_view_effects), "--view_effects",
                                              &options.effects);
      !st.ok()) {
    return st;
  }
  if (absl::GetFlag(FLAGS_on_server)) {
    return AddModelOnServer(*ObjectClient::Connect(server, {.connection = connection}), model,
                            options);
  }
  std::fprintf(stderr, "rendering training views of %s...\n", model.c_str());
  absl::StatusOr<std::vector<v1::TrainingFrame>> frames = ModelTrainingFrames(model, options);
  if (!frames.ok()) return frames.status();
  std::unique_ptr<ObjectClient> client = ObjectClient::Connect(server, {.connection = connection});
  v1::TrainObjectRequest header;
  header.set_obj_id(id);
  header.set_display_name(absl::GetFlag(FLAGS_name).empty() ? fs::path(model).stem().string()
                                                            : absl::GetFlag(FLAGS_name));
  *header.mutable_params() = ParamsFromFlags();
  size_t next = 0;
  absl::StatusOr<v1::Object> trained =
      client->TrainObject(header, [&]() -> absl::StatusOr<std::optional<v1::TrainingFrame>> {
        if (next == frames->size()) {
          std::fprintf(stderr, "\rtraining objects/%d: %zu views sent, mean shift...\n", id,
                       frames->size());
          return std::optional<v1::TrainingFrame>();
        }
        std::fprintf(stderr, "\rtraining objects/%d: view %zu/%zu sent  ", id, next + 1,
                     frames->size());
        return std::optional<v1::TrainingFrame>(std::move((*frames)[next++]));
      });
  if (!trained.ok()) return trained.status();
  PrintObject(*trained);
  return absl::OkStatus();
}

// keep_trained: an object the server already has is kept (and said so), not retrained.
absl::Status Train(ObjectClient& client, const std::string& dataset, bool keep_trained) {
  const int only = absl::GetFlag(FLAGS_object);
  if (absl::GetFlag(FLAGS_on_server)) {
    if (only <= 0) return absl::InvalidArgumentError("--on_server needs --object=ID");
    v1::TrainObjectFromDatasetRequest request;
    request.set_dataset_path(fs::absolute(dataset).string());
    request.set_obj_id(only);
    request.set_display_name(absl::GetFlag(FLAGS_name));
    *request.mutable_params() = ParamsFromFlags();
    request.set_frame_stride(std::max(1, absl::GetFlag(FLAGS_frame_stride)));
    absl::StatusOr<v1::Operation> op = client.TrainObjectFromDataset(request);
    if (!op.ok()) return op.status();
    op = client.WaitDone(op->name(), PrintProgress);
    if (!op.ok()) return op.status();
    PrintObject(op->object());
    return absl::OkStatus();
  }
  std::vector<TrainingObject> objects;
  if (fs::exists(fs::path(dataset) / "scene_gt.json")) {
    if (only <= 0) return absl::InvalidArgumentError("a scene folder needs --object=ID");
    objects.push_back({only, dataset, ""});
  } else {
    absl::StatusOr<std::vector<TrainingObject>> all = ListTrainingObjects(dataset);
    if (!all.ok()) return all.status();
    for (const TrainingObject& o : *all) {
      if (only <= 0 || o.obj_id == only) objects.push_back(o);
    }
    if (objects.empty()) {
      return absl::NotFoundError(absl::StrCat(dataset, ": no train/ folder for object ", only));
    }
  }
  for (TrainingObject& o : objects) {
    if (keep_trained) {
      const std::string name = absl::StrCat("objects/", o.obj_id);
      absl::StatusOr<v1::Object> existing = client.GetObject(name);
      if (existing.ok()) {
        std::printf("%s is already trained: kept (delete it to retrain)\n", name.c_str());
        continue;
      }
      if (!absl::IsNotFound(existing.status())) return existing.status();
    }
    if (!absl::GetFlag(FLAGS_name).empty()) o.name = absl::GetFlag(FLAGS_name);
    absl::StatusOr<v1::Object> trained = StreamObject(client, o);
    if (!trained.ok()) return trained.status();
    PrintObject(*trained);
  }
  return absl::OkStatus();
}

absl::Status Build(ObjectClient& client) {
  v1::BuildClassifierRequest request;
  if (int k = absl::GetFlag(FLAGS_classes_per_object); k > 0) {
    request.mutable_params()->set_classes_per_object(k);
  }
  if (int t = absl::GetFlag(FLAGS_trees); t > 0) request.mutable_params()->set_trees(t);
  if (int d = absl::GetFlag(FLAGS_tree_depth); d > 0) request.mutable_params()->set_max_depth(d);
  if (double v = absl::GetFlag(FLAGS_verify_threshold); v != 0) {
    request.mutable_params()->set_verify_threshold(v);
  }
  // Out of range (1..64): the server's error names params.top_n.
  if (int n = absl::GetFlag(FLAGS_top_n); n != 0) request.mutable_params()->set_top_n(n);
  absl::StatusOr<v1::Operation> op = client.BuildClassifier(request);
  if (!op.ok()) return op.status();
  op = client.WaitDone(op->name(), PrintProgress);
  if (!op.ok()) return op.status();
  const v1::Classifier& c = op->classifier();
  std::printf("classifier ready: %d objects, %u classes, %u trees x depth %u, %.1f MiB\n",
              c.objects_size(), c.classes(), c.params().trees(), c.params().max_depth(),
              c.model_bytes() / 1048576.0);
  std::printf("verification: descriptor distance <= %g, %u candidate classes per feature\n",
              c.params().verify_threshold(), c.params().top_n());
  std::printf(
      "maps list its instances at score >= %g (scaled by size), fit >= %g, view "
      "conflict <= %g (%s's; a map may set its own)\n",
      c.params().min_instance_score(), c.params().min_instance_fit(),
      c.params().max_view_conflict(), c.detector().c_str());
  return absl::OkStatus();
}

absl::StatusOr<std::string> ObjectArg(const std::vector<std::string>& args) {
  if (args.size() < 4) return absl::InvalidArgumentError("objects: this verb needs an object ID");
  int id = 0;
  if (!absl::SimpleAtoi(args[3], &id)) {
    return absl::InvalidArgumentError(
        absl::StrCat("objects: ID \"", args[3], "\" is not a number"));
  }
  return absl::StrCat("objects/", id);
}

}  // namespace

absl::Status TrainAndBuild(const std::string& server, const std::string& dataset,
                           const Connection& connection) {
  std::unique_ptr<ObjectClient> client = ObjectClient::Connect(server, {.connection = connection});
  if (absl::Status s = Train(*client, dataset, /*keep_trained=*/true); !s.ok()) return s;
  return Build(*client);
}

int RunObjectsCommand(const std::string& server, const std::vector<std::string>& args,
                      const Connection& connection) {
  const std::string verb = args.size() > 2 ? args[2] : "ls";
  if (verb == "add") {  // connects after rendering
    if (args.size() < 4) return Fail(absl::InvalidArgumentError("objects add needs a MODEL file"));
    return Exit(AddModel(server, connection, args[3]));
  }
  std::unique_ptr<ObjectClient> client = ObjectClient::Connect(server, {.connection = connection});
  if (verb == "ls") {
    absl::StatusOr<std::vector<v1::Object>> objects = client->ListAllObjects();
    if (!objects.ok()) return Fail(objects.status());
    for (const v1::Object& o : *objects) PrintObject(o);
    if (objects->empty()) std::printf("(no objects)\n");
    return 0;
  }
  if (verb == "classifier") {
    absl::StatusOr<v1::Classifier> c = client->GetClassifier();
    if (!c.ok()) return Fail(c.status());
    std::printf("%s\n", c->DebugString().c_str());
    return 0;
  }
  if (verb == "build") return Exit(Build(*client));
  if (verb == "train") {
    if (args.size() < 4) return Fail(absl::InvalidArgumentError("objects train needs a DATASET"));
    return Exit(Train(*client, args[3], /*keep_trained=*/false));
  }
  if (verb == "rm" || verb == "info") {
    absl::StatusOr<std::string> name = ObjectArg(args);
    if (!name.ok()) return Fail(name.status());
    if (verb == "rm") {
      if (absl::Status s = client->DeleteObject(*name); !s.ok()) return Fail(s);
      std::printf("deleted %s\n", name->c_str());
      return 0;
    }
    absl::StatusOr<v1::Object> o = client->GetObject(*name);
    if (!o.ok()) return Fail(o.status());
    std::printf("%s\n", o->DebugString().c_str());
    return 0;
  }
  std::fprintf(stderr,
               "skimap: objects ls | info ID | rm ID | train DATASET | add MODEL | build | "
               "classifier\n");
  return 2;
}

}  // namespace skimap::client
