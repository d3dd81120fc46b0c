// ObjectService: objects trained from their 3D models (AddObjectModel). The upload is
// written to a private folder, skimap-model-views renders it into a BOP scene there
// (model_renderer.h), and the scene trains as TrainObjectFromDataset's do.
#include <filesystem>

#include "absl/strings/str_cat.h"
#include "server/core/objects/model_upload.h"
#include "server/core/objects/object_codec.h"
#include "server/core/objects/object_service.h"

namespace skimap::server {
namespace fs = std::filesystem;

struct ObjectService::ModelSession {
  explicit ModelSession(std::atomic<int>* open) : open(open) {}
  ~ModelSession() { --*open; }
  std::atomic<int>* const open;
  v1::AddObjectModelRequest first;  // without its file piece
  objects::ObjectDatabaseParams params;
  std::unique_ptr<ModelUpload> upload;
};

absl::StatusOr<std::shared_ptr<ObjectService::ModelSession>> ObjectService::StartModelUpload(
    const v1::AddObjectModelRequest& first) {
  if (options_.model_renderer.binary.empty()) {
    return absl::FailedPreconditionError(
        "model: this server renders no models (skimapd --model_renderer); train with "
        "`skimap objects add MODEL`, which renders on the client");
  }
  if (absl::Status s = CheckObjId(first.obj_id()); !s.ok()) return s;
  if (absl::Status s = registry_->CheckNew(static_cast<int>(first.obj_id())); !s.ok()) return s;
  if (absl::Status s = CheckModelFileName(first.model(), "model"); !s.ok()) return s;
  if (absl::Status s = CheckModelViews(first.views()); !s.ok()) return s;
  absl::StatusOr<objects::ObjectDatabaseParams> params = TrainingParamsFor(first.params());
  if (!params.ok()) return params.status();
  if (++model_uploads_ > options_.max_model_uploads) {
    --model_uploads_;
    return absl::ResourceExhaustedError(
        absl::StrCat("model uploads: ", options_.max_model_uploads, " are running, retry later"));
  }
  auto session = std::make_shared<ModelSession>(&model_uploads_);
  absl::StatusOr<std::unique_ptr<ModelUpload>> upload =
      ModelUpload::Create(options_.model_scratch_dir, {});
  if (!upload.ok()) return upload.status();
  session->upload = *std::move(upload);
  session->first = first;
  session->first.clear_file();
  session->params = *std::move(params);
  return session;
}

absl::Status ObjectService::AddModelPiece(ModelSession& session,
                                          const v1::AddObjectModelRequest& request) {
  if (!request.has_file()) return absl::OkStatus();
  return session.upload->Add(request.file());
}

absl::StatusOr<v1::Operation> ObjectService::FinishModelUpload(
    std::shared_ptr<ModelSession> session) {
  const v1::AddObjectModelRequest& first = session->first;
  if (absl::Status s = session->upload->Seal(first.model()); !s.ok()) return s;
  return StartTrainingJob(
      "AddObjectModel", session->params,
      [this, session](const std::string& op) -> absl::StatusOr<objects::ObjectModel> {
        const v1::AddObjectModelRequest& first = session->first;
        const int obj_id = static_cast<int>(first.obj_id());
        v1::OperationProgress pr;
        pr.set_stage("rendering");
        operations_.SetProgress(op, pr);
        const absl::Status rendered =
            RenderModelViews(options_.model_renderer, session->upload->dir().string(),
                             first.model(), first.views(), obj_id, "views");
        std::string name = first.display_name();
        if (name.empty()) name = fs::path(first.model()).stem().string();
        absl::StatusOr<objects::ObjectModel> model =
            rendered.ok() ? TrainSceneAndStore(op, (session->upload->dir() / "views").string(),
                                               obj_id, name, session->params, 1, 0.1)
                          : rendered;
        session->upload.reset();  // the folder goes before the operation says it is done
        return model;
      });
}

}  // namespace skimap::server
