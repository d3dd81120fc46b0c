#include "server/grpc/object_grpc_service.h"

#include <memory>
#include <mutex>
#include <utility>

#include "server/core/auth/access.h"
#include "server/grpc/grpc_auth.h"
#include "server/grpc/grpc_status.h"

namespace skimap::server {
namespace {

using auth::Role;
using grpc::CallbackServerContext;
using grpc::ServerUnaryReactor;

// TrainObject: one message read at a time; its frame is fused on the core's training
// worker and the next read starts from that worker's callback. The reactor is deleted in
// OnDone, which gRPC runs only after Finish; every core callback runs before Finish.
class TrainObjectReactor final : public grpc::ServerReadReactor<v1::TrainObjectRequest> {
 public:
  TrainObjectReactor(ObjectService* core, CallbackServerContext* ctx, v1::Object* response)
      : core_(core), ctx_(ctx), response_(response) {
    StartRead(&request_);
  }
  void OnReadDone(bool ok) override {
    if (!ok) {
      if (ctx_->IsCancelled()) return Finish(grpc::Status::CANCELLED);
      if (session_ == nullptr) {
        return Finish(
            grpc::Status(grpc::StatusCode::INVALID_ARGUMENT, "obj_id: the stream sent no message"));
      }
      return core_->FinishTraining(session_, [this](absl::StatusOr<v1::Object> object) {
        if (object.ok()) *response_ = *std::move(object);
        Finish(ToGrpcStatus(object.status()));
      });
    }
    if (session_ == nullptr) {
      absl::StatusOr<std::shared_ptr<ObjectService::TrainingSession>> s =
          core_->StartTraining(request_);
      if (!s.ok()) return Finish(ToGrpcStatus(s.status()));
      session_ = *std::move(s);
    }
    auto message = std::make_shared<const v1::TrainObjectRequest>(std::move(request_));
    request_.Clear();
    core_->AddTrainingFrame(session_, std::move(message), [this](absl::Status s) {
      if (!s.ok()) return Finish(ToGrpcStatus(s));
      StartRead(&request_);
    });
  }
  void OnDone() override { delete this; }

 private:
  ObjectService* const core_;
  CallbackServerContext* const ctx_;
  v1::Object* const response_;
  v1::TrainObjectRequest request_;
  std::shared_ptr<ObjectService::TrainingSession> session_;
};

// AddObjectModel: each message's file piece is written on gRPC's thread (disk writes of at
// most a message's size) before the next read; the stream's end starts the operation.
class AddObjectModelReactor final : public grpc::ServerReadReactor<v1::AddObjectModelRequest> {
 public:
  AddObjectModelReactor(ObjectService* core, CallbackServerContext* ctx, v1::Operation* response)
      : core_(core), ctx_(ctx), response_(response) {
    StartRead(&request_);
  }
  void OnReadDone(bool ok) override {
    if (!ok) {
      if (ctx_->IsCancelled()) return Finish(grpc::Status::CANCELLED);
      if (session_ == nullptr) {
        return Finish(
            grpc::Status(grpc::StatusCode::INVALID_ARGUMENT, "obj_id: the stream sent no message"));
      }
      absl::StatusOr<v1::Operation> op = core_->FinishModelUpload(std::move(session_));
      if (op.ok()) *response_ = *std::move(op);
      return Finish(ToGrpcStatus(op.status()));
    }
    if (session_ == nullptr) {
      absl::StatusOr<std::shared_ptr<ObjectService::ModelSession>> s =
          core_->StartModelUpload(request_);
      if (!s.ok()) return Finish(ToGrpcStatus(s.status()));
      session_ = *std::move(s);
    }
    if (absl::Status s = core_->AddModelPiece(*session_, request_); !s.ok()) {
      session_.reset();
      return Finish(ToGrpcStatus(s));
    }
    request_.Clear();
    StartRead(&request_);
  }
  void OnDone() override { delete this; }

 private:
  ObjectService* const core_;
  CallbackServerContext* const ctx_;
  v1::Operation* const response_;
  v1::AddObjectModelRequest request_;
  std::shared_ptr<ObjectService::ModelSession> session_;
};

// WaitOperation: finished by the core's callback or by cancellation, whichever is first;
// the shared state outlives the reactor so a late callback finds it finished.
class WaitOperationReactor final : public ServerUnaryReactor {
 public:
  struct State {
    std::mutex mu;
    WaitOperationReactor* reactor = nullptr;  // valid until finished
    v1::Operation* response = nullptr;
    bool finished = false;
  };
  explicit WaitOperationReactor(v1::Operation* response) : state_(std::make_shared<State>()) {
    state_->reactor = this;
    state_->response = response;
  }
  static void Complete(const std::shared_ptr<State>& state, absl::StatusOr<v1::Operation> op) {
    WaitOperationReactor* reactor = nullptr;
    {
      std::lock_guard<std::mutex> lock(state->mu);
      if (state->finished) return;
      state->finished = true;
      if (op.ok()) *state->response = *std::move(op);
      reactor = state->reactor;
    }
    reactor->Finish(ToGrpcStatus(op.status()));
  }
  void OnCancel() override { Complete(state_, absl::CancelledError("cancelled")); }
  void OnDone() override { delete this; }
  const std::shared_ptr<State>& state() const { return state_; }

 private:
  std::shared_ptr<State> state_;
};

}  // namespace

absl::Status GrpcObjectService::Allow(CallbackServerContext* ctx, Role needed) const {
  return CheckCall(auth_, ctx, needed).status();
}

grpc::ServerReadReactor<v1::TrainObjectRequest>* GrpcObjectService::TrainObject(
    CallbackServerContext* ctx, v1::Object* response) {
  if (absl::Status s = Allow(ctx, auth::MethodRole("ObjectService/TrainObject")); !s.ok()) {
    return new RefusedCall<grpc::ServerReadReactor<v1::TrainObjectRequest>>(s);
  }
  return new TrainObjectReactor(core_, ctx, response);
}

grpc::ServerReadReactor<v1::AddObjectModelRequest>* GrpcObjectService::AddObjectModel(
    CallbackServerContext* ctx, v1::Operation* response) {
  if (absl::Status s = Allow(ctx, auth::MethodRole("ObjectService/AddObjectModel")); !s.ok()) {
    return new RefusedCall<grpc::ServerReadReactor<v1::AddObjectModelRequest>>(s);
  }
  return new AddObjectModelReactor(core_, ctx, response);
}

ServerUnaryReactor* GrpcObjectService::TrainObjectFromDataset(
    CallbackServerContext* ctx, const v1::TrainObjectFromDatasetRequest* request,
    v1::Operation* response) {
  if (absl::Status s = Allow(ctx, auth::MethodRole("ObjectService/TrainObjectFromDataset"));
      !s.ok())
    return Refuse(ctx, s);
  return Reply(ctx, core_->TrainObjectFromDataset(*request), response);
}

ServerUnaryReactor* GrpcObjectService::ListObjects(CallbackServerContext* ctx,
                                                   const v1::ListObjectsRequest* request,
                                                   v1::ListObjectsResponse* response) {
  if (absl::Status s = Allow(ctx, auth::MethodRole("ObjectService/ListObjects")); !s.ok())
    return Refuse(ctx, s);
  return Reply(ctx, core_->ListObjects(*request), response);
}

ServerUnaryReactor* GrpcObjectService::GetObject(CallbackServerContext* ctx,
                                                 const v1::GetObjectRequest* request,
                                                 v1::Object* response) {
  if (absl::Status s = Allow(ctx, auth::MethodRole("ObjectService/GetObject")); !s.ok())
    return Refuse(ctx, s);
  return Reply(ctx, core_->GetObject(*request), response);
}

ServerUnaryReactor* GrpcObjectService::DeleteObject(CallbackServerContext* ctx,
                                                    const v1::DeleteObjectRequest* request,
                                                    v1::DeleteObjectResponse* response) {
  if (absl::Status s = Allow(ctx, auth::MethodRole("ObjectService/DeleteObject")); !s.ok())
    return Refuse(ctx, s);
  ServerUnaryReactor* reactor = ctx->DefaultReactor();
  reactor->Finish(ToGrpcStatus(core_->DeleteObject(*request)));
  return reactor;
}

ServerUnaryReactor* GrpcObjectService::BuildClassifier(CallbackServerContext* ctx,
                                                       const v1::BuildClassifierRequest* request,
                                                       v1::Operation* response) {
  if (absl::Status s = Allow(ctx, auth::MethodRole("ObjectService/BuildClassifier")); !s.ok())
    return Refuse(ctx, s);
  return Reply(ctx, core_->BuildClassifier(*request), response);
}

ServerUnaryReactor* GrpcObjectService::GetClassifier(CallbackServerContext* ctx,
                                                     const v1::GetClassifierRequest* request,
                                                     v1::Classifier* response) {
  if (absl::Status s = Allow(ctx, auth::MethodRole("ObjectService/GetClassifier")); !s.ok())
    return Refuse(ctx, s);
  return Reply(ctx, absl::StatusOr<v1::Classifier>(core_->GetClassifier()), response);
}

ServerUnaryReactor* GrpcObjectService::ClassifyImage(CallbackServerContext* ctx,
                                                     const v1::ClassifyImageRequest* request,
                                                     v1::ClassifyImageResponse* response) {
  if (absl::Status s = Allow(ctx, auth::MethodRole("ObjectService/ClassifyImage")); !s.ok())
    return Refuse(ctx, s);
  return Reply(ctx, core_->ClassifyImage(*request), response);
}

ServerUnaryReactor* GrpcObjectService::GetOperation(CallbackServerContext* ctx,
                                                    const v1::GetOperationRequest* request,
                                                    v1::Operation* response) {
  if (absl::Status s = Allow(ctx, auth::MethodRole("ObjectService/GetOperation")); !s.ok())
    return Refuse(ctx, s);
  return Reply(ctx, core_->GetOperation(*request), response);
}

ServerUnaryReactor* GrpcObjectService::WaitOperation(CallbackServerContext* ctx,
                                                     const v1::WaitOperationRequest* request,
                                                     v1::Operation* response) {
  if (absl::Status s = Allow(ctx, auth::MethodRole("ObjectService/WaitOperation")); !s.ok())
    return Refuse(ctx, s);
  auto* reactor = new WaitOperationReactor(response);
  std::shared_ptr<WaitOperationReactor::State> state = reactor->state();
  core_->WaitOperation(*request, [state](absl::StatusOr<v1::Operation> op) {
    WaitOperationReactor::Complete(state, std::move(op));
  });
  return reactor;
}

}  // namespace skimap::server
