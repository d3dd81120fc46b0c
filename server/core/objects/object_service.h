// ObjectService: the transport-independent core of skimap.v1.ObjectService
// (proto/skimap/v1/objects.proto). Methods take and return the API's messages and report
// absl::Status with the codes documented in objects.proto; the gRPC adapter
// (object_grpc_service.h) converts them once.
//
//   auto service = ObjectService::Create({.db_path = data_dir + "/objects.sqlite"});
//   auto session = (*service)->StartTraining(first_message);      // streamed training
//   (*service)->AddTrainingFrame(*session, message, [](absl::Status s) { ... });
//   (*service)->FinishTraining(*session, [](absl::StatusOr<v1::Object> o) { ... });
//   absl::StatusOr<v1::Operation> op = (*service)->BuildClassifier(request);
//
// Work: streamed frames and their mean shift run on one training worker (a frame at a
// time per stream: the caller sends the next frame after `done`); dataset training and
// classifier builds run on one job worker, in order. Neither blocks the calling thread.
// Shutdown (the destructor) finishes every queued task first.
//
// Thread safety: thread safe; every method may be called from any thread.
#ifndef SERVER_CORE_OBJECTS_OBJECT_SERVICE_H_
#define SERVER_CORE_OBJECTS_OBJECT_SERVICE_H_

#include <atomic>
#include <functional>
#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "server/core/common/work_queue.h"
#include "server/core/objects/model_renderer.h"
#include "server/core/objects/object_registry.h"
#include "server/core/objects/operation_table.h"
#include "skimap/v1/objects.pb.h"

namespace skimap::server {

class ObjectService {
 public:
  struct Options {
    std::string db_path;          // SQLite file (skimapd: DATA_DIR/objects.sqlite); "" = memory
    int threads = 2;              // mean shift and forest threads, >= 1
    size_t max_operations = 100;  // finished operations kept
    size_t max_queued_jobs = 16;  // dataset trainings + builds waiting; more: RESOURCE_EXHAUSTED
    // TrainObjectFromDataset reads datasets on the server's disk only under this directory;
    // "" (the default) turns it off (PermissionDenied). See dataset_root.h.
    std::string dataset_root;
    // AddObjectModel: the renderer (binary "" turns the call off: FailedPrecondition) and
    // the folder uploads are written to (each in a folder of its own, removed after).
    ModelRendererOptions model_renderer;
    std::string model_scratch_dir;
    int max_model_uploads = 4;  // streams at a time; more: RESOURCE_EXHAUSTED
  };
  // Opens the registry (loads the stored objects and classifier).
  static absl::StatusOr<std::unique_ptr<ObjectService>> Create(const Options& options);
  ~ObjectService();

  // ---- TrainObject (client stream) ----
  struct TrainingSession;  // one streamed training; opaque
  // Validates the first message's obj_id (InvalidArgument, AlreadyExists) and params
  // (InvalidArgument "params.*", FailedPrecondition if they differ from the database's).
  absl::StatusOr<std::shared_ptr<TrainingSession>> StartTraining(
      const v1::TrainObjectRequest& first);
  // Decodes and fuses the message's frame (if any) on the training worker; done(status)
  // runs exactly once (InvalidArgument "frames[i].<field>: ..." for a bad frame).
  void AddTrainingFrame(std::shared_ptr<TrainingSession> session,
                        std::shared_ptr<const v1::TrainObjectRequest> request,
                        std::function<void(absl::Status)> done);
  // Mean shift, then stores the object; done runs exactly once. FailedPrecondition if no
  // frame contributed a descriptor.
  void FinishTraining(std::shared_ptr<TrainingSession> session,
                      std::function<void(absl::StatusOr<v1::Object>)> done);

  // ---- AddObjectModel (client stream) ----
  struct ModelSession;  // one streamed model; opaque
  // Validates the first message (obj_id, model, views, params) and opens the upload.
  absl::StatusOr<std::shared_ptr<ModelSession>> StartModelUpload(
      const v1::AddObjectModelRequest& first);
  // Writes the message's file piece (if any); InvalidArgument "file.*" past the limits.
  absl::Status AddModelPiece(ModelSession& session, const v1::AddObjectModelRequest& request);
  // Starts the operation (render, train, store) that owns the upload from now on.
  absl::StatusOr<v1::Operation> FinishModelUpload(std::shared_ptr<ModelSession> session);

  // ---- Unary methods ----
  absl::StatusOr<v1::Operation> TrainObjectFromDataset(
      const v1::TrainObjectFromDatasetRequest& request);
  absl::StatusOr<v1::ListObjectsResponse> ListObjects(const v1::ListObjectsRequest& request) const;
  absl::StatusOr<v1::Object> GetObject(const v1::GetObjectRequest& request) const;
  absl::Status DeleteObject(const v1::DeleteObjectRequest& request);
  absl::StatusOr<v1::Operation> BuildClassifier(const v1::BuildClassifierRequest& request);
  v1::Classifier GetClassifier() const;
  absl::StatusOr<v1::ClassifyImageResponse> ClassifyImage(
      const v1::ClassifyImageRequest& request) const;
  absl::StatusOr<v1::Operation> GetOperation(const v1::GetOperationRequest& request) const;
  // done runs exactly once: when the operation is done or after the request's timeout.
  void WaitOperation(const v1::WaitOperationRequest& request, OperationTable::WaitDone done);

  ObjectRegistry& registry() { return *registry_; }

 private:
  explicit ObjectService(const Options& options);
  // The params a new object trains with: `api` over the database's (or the defaults).
  absl::StatusOr<objects::ObjectDatabaseParams> TrainingParamsFor(
      const v1::TrainingParams& api) const;
  // Starts operation `kind` whose job (on the job worker) trains and stores one object:
  // its result is the Object (with `p`), its error the job's. ResourceExhausted when the
  // job queue is full.
  absl::StatusOr<v1::Operation> StartTrainingJob(
      const std::string& kind, objects::ObjectDatabaseParams p,
      std::function<absl::StatusOr<objects::ObjectModel>(const std::string& operation)> job);
  // On the job worker: trains obj_id from the BOP scene folder (every stride-th frame) and
  // stores it, reporting progress to `operation` (frames from `start` to 0.8 of it, mean
  // shift to 0.95, then saving). The stored object's model.
  absl::StatusOr<objects::ObjectModel> TrainSceneAndStore(const std::string& operation,
                                                          const std::string& scene, int obj_id,
                                                          const std::string& name,
                                                          const objects::ObjectDatabaseParams& p,
                                                          int stride, double start);
  void RunBuild(const std::string& operation, const v1::ClassifierParams& api,
                ObjectRegistry::BuildInput input);

  const Options options_;
  std::unique_ptr<ObjectRegistry> registry_;
  OperationTable operations_;
  std::atomic<int> model_uploads_{0};  // open ModelSessions
  // Declared last: destroyed (drained) first, while the registry and table still exist.
  WorkQueue training_worker_;
  WorkQueue job_worker_;
};

}  // namespace skimap::server

#endif  // SERVER_CORE_OBJECTS_OBJECT_SERVICE_H_
