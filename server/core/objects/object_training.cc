// ObjectService: training (streamed frames and server-side datasets).
#include <filesystem>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "base/echo.h"
#include "perception/objects/training.h"
#include "server/core/objects/dataset_root.h"
#include "server/core/objects/object_codec.h"
#include "server/core/objects/object_service.h"

namespace skimap::server {
namespace fs = std::filesystem;

struct ObjectService::TrainingSession {
  objects::ObjectDatabaseParams params;
  std::unique_ptr<objects::ObjectTrainer> trainer;  // used on the training worker only
  int64_t frames = 0;                               // messages with a frame so far
};

absl::StatusOr<objects::ObjectDatabaseParams> ObjectService::TrainingParamsFor(
    const v1::TrainingParams& api) const {
  std::optional<objects::ObjectDatabaseParams> base = registry_->params();
  if (!base) {
    base = objects::ObjectDatabaseParams{};
    base->forest.threads = options_.threads;
  }
  absl::StatusOr<objects::ObjectDatabaseParams> p = ApplyTrainingParams(api, *base);
  if (!p.ok()) return p.status();
  if (std::optional<objects::ObjectDatabaseParams> db = registry_->params()) {
    if (absl::Status s = CheckSameTraining(*p, *db); !s.ok()) return s;
  }
  return p;
}

absl::StatusOr<std::shared_ptr<ObjectService::TrainingSession>> ObjectService::StartTraining(
    const v1::TrainObjectRequest& first) {
  if (absl::Status s = CheckObjId(first.obj_id()); !s.ok()) return s;
  if (absl::Status s = registry_->CheckNew(static_cast<int>(first.obj_id())); !s.ok()) return s;
  absl::StatusOr<objects::ObjectDatabaseParams> params = TrainingParamsFor(first.params());
  if (!params.ok()) return params.status();
  absl::StatusOr<std::unique_ptr<objects::ObjectTrainer>> trainer = objects::ObjectTrainer::Create(
      static_cast<int>(first.obj_id()), first.display_name(), *params);
  if (!trainer.ok()) return trainer.status();
  auto session = std::make_shared<TrainingSession>();
  session->params = *std::move(params);
  session->trainer = *std::move(trainer);
  return session;
}

void ObjectService::AddTrainingFrame(std::shared_ptr<TrainingSession> session,
                                     std::shared_ptr<const v1::TrainObjectRequest> request,
                                     std::function<void(absl::Status)> done) {
  if (!request->has_frame()) return done(absl::OkStatus());
  const bool queued = training_worker_.TrySubmit([session, request, done] {
    const int64_t index = session->frames++;
    auto fail = [&](const absl::Status& s) {
      return absl::Status(s.code(), absl::StrCat("frames[", index, "].", s.message()));
    };
    absl::StatusOr<objects::TrainingFrame> frame = DecodeTrainingFrame(request->frame());
    if (!frame.ok()) return done(fail(frame.status()));
    absl::StatusOr<objects::FrameContribution> c = session->trainer->AddFrame(*frame);
    done(c.ok() ? absl::OkStatus() : fail(c.status()));
  });
  if (!queued) done(absl::ResourceExhaustedError("training worker: queue full, retry later"));
}

void ObjectService::FinishTraining(std::shared_ptr<TrainingSession> session,
                                   std::function<void(absl::StatusOr<v1::Object>)> done) {
  const bool queued = training_worker_.TrySubmit([this, session, done] {
    if (session->frames == 0) {
      return done(absl::InvalidArgumentError("frames: no training frame was sent"));
    }
    absl::StatusOr<objects::TrainedObject> trained = session->trainer->Finish(options_.threads);
    if (!trained.ok()) return done(trained.status());
    const objects::ObjectModel model = trained->model;
    if (absl::Status s = registry_->Add(*std::move(trained), session->params); !s.ok()) {
      return done(s);
    }
    done(ToApiObject(model, session->params, false));
  });
  if (!queued) done(absl::ResourceExhaustedError("training worker: queue full, retry later"));
}

absl::StatusOr<objects::ObjectModel> ObjectService::TrainSceneAndStore(
    const std::string& op, const std::string& scene, int obj_id, const std::string& name,
    const objects::ObjectDatabaseParams& p, int stride, double start) {
  objects::DatasetTrainingOptions o;
  o.threads = options_.threads;
  o.use_frame = [stride](int, int frame_id) { return frame_id % stride == 0; };
  o.progress = [&](const objects::BuildProgress& b) {
    v1::OperationProgress pr;
    pr.set_stage(b.stage);
    pr.set_done(b.done);
    pr.set_total(b.total);
    const double f = b.total > 0 ? double(b.done) / double(b.total) : 0;
    pr.set_fraction(b.stage == "frames" ? start + (0.8 - start) * f : 0.8 + 0.15 * f);
    operations_.SetProgress(op, pr);
  };
  absl::StatusOr<objects::TrainedObject> trained = objects::TrainObject(scene, obj_id, name, p, o);
  if (!trained.ok()) return trained.status();
  objects::ObjectModel model = trained->model;
  v1::OperationProgress pr;
  pr.set_stage("saving");
  pr.set_fraction(0.95);
  operations_.SetProgress(op, pr);
  if (absl::Status s = registry_->Add(*std::move(trained), p); !s.ok()) return s;
  return model;
}

absl::StatusOr<v1::Operation> ObjectService::TrainObjectFromDataset(
    const v1::TrainObjectFromDatasetRequest& request) {
  if (options_.dataset_root.empty()) {
    return absl::PermissionDeniedError(
        "dataset_path: this server reads no datasets (start skimapd with --dataset_root)");
  }
  if (request.dataset_path().empty()) {
    return absl::InvalidArgumentError("dataset_path: required (a BOP dataset root or scene)");
  }
  if (absl::Status s = CheckObjId(request.obj_id()); !s.ok()) return s;
  const int obj_id = static_cast<int>(request.obj_id());
  if (absl::Status s = registry_->CheckNew(obj_id); !s.ok()) return s;
  absl::StatusOr<objects::ObjectDatabaseParams> params = TrainingParamsFor(request.params());
  if (!params.ok()) return params.status();
  absl::StatusOr<fs::path> resolved =
      ResolveUnderRoot(options_.dataset_root, request.dataset_path(), "dataset_path");
  if (!resolved.ok()) return resolved.status();
  const fs::path& root = *resolved;
  const fs::path train = root / "train" / absl::StrFormat("%06d", obj_id);
  std::error_code ec;
  fs::path scene;
  if (fs::is_directory(train, ec)) {
    scene = train;
  } else if (fs::is_regular_file(root / "scene_gt.json", ec)) {
    scene = root;
  } else {
    return absl::NotFoundError(
        absl::StrCat("dataset_path: neither train/", absl::StrFormat("%06d", obj_id),
                     " nor a BOP scene (scene_gt.json) at ", Echo(request.dataset_path())));
  }
  std::string name = request.display_name();
  if (name.empty() && scene == train) {
    absl::StatusOr<std::vector<std::pair<int, std::string>>> names =
        objects::ListTrainingObjects(root.string());
    if (names.ok()) {
      for (const auto& [id, n] : *names) {
        if (id == obj_id) name = n;
      }
    }
  }
  const int stride = std::max(1, static_cast<int>(request.frame_stride()));
  return StartTrainingJob("TrainObjectFromDataset", *params,
                          [this, scene, obj_id, name, stride, p = *params](const std::string& op) {
                            return TrainSceneAndStore(op, scene.string(), obj_id, name, p, stride,
                                                      0);
                          });
}

absl::StatusOr<v1::Operation> ObjectService::StartTrainingJob(
    const std::string& kind, objects::ObjectDatabaseParams p,
    std::function<absl::StatusOr<objects::ObjectModel>(const std::string&)> job) {
  const std::string op = operations_.Start(kind);
  const bool queued = job_worker_.TrySubmit([this, op, p = std::move(p), job = std::move(job)] {
    const absl::StatusOr<objects::ObjectModel> model = job(op);
    operations_.Finish(op, model.status(), [&](v1::Operation* out) {
      *out->mutable_object() = ToApiObject(*model, p, false);
    });
  });
  if (!queued) {
    operations_.Finish(op, absl::ResourceExhaustedError("job queue full"), nullptr);
    return absl::ResourceExhaustedError("jobs: queue full, retry later");
  }
  return operations_.Get(op);
}

}  // namespace skimap::server
