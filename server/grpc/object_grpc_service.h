// GrpcObjectService: the gRPC adapter of ObjectService (callback API). Each unary handler
// calls the core and converts the status once (grpc_status.h).
//
// Routes (skimap.v1.ObjectService): TrainObjectFromDataset, ListObjects, GetObject,
// DeleteObject, BuildClassifier, GetClassifier, ClassifyImage, GetOperation (unary);
// TrainObject (client stream: reads the next message only after the previous frame was
// fused, so a fast client is held back by flow control); WaitOperation (unary, answered
// when the operation is done or on timeout; cancellation answers at once); AddObjectModel
// (client stream: each file piece is written before the next read; the answer is the
// operation that renders and trains).
//
// Thread safety: stateless apart from the core pointer; safe for concurrent calls.
#ifndef SERVER_GRPC_OBJECT_GRPC_SERVICE_H_
#define SERVER_GRPC_OBJECT_GRPC_SERVICE_H_

#include <grpcpp/grpcpp.h>

#include "server/core/auth/authorizer.h"
#include "server/core/objects/object_service.h"
#include "skimap/v1/objects.grpc.pb.h"

namespace skimap::server {

class GrpcObjectService final : public v1::ObjectService::CallbackService {
 public:
  // REQUIRES: core (and auth, if not null) outlive this service and every call it started.
  // With `auth`, every call is authorized first (grpc_auth.h; the roles: docs/operations.md).
  explicit GrpcObjectService(ObjectService* core, const auth::Authorizer* auth = nullptr)
      : core_(core), auth_(auth) {}

  grpc::ServerReadReactor<v1::TrainObjectRequest>* TrainObject(grpc::CallbackServerContext* ctx,
                                                               v1::Object* response) override;
  grpc::ServerReadReactor<v1::AddObjectModelRequest>* AddObjectModel(
      grpc::CallbackServerContext* ctx, v1::Operation* response) override;
  grpc::ServerUnaryReactor* TrainObjectFromDataset(grpc::CallbackServerContext* ctx,
                                                   const v1::TrainObjectFromDatasetRequest* request,
                                                   v1::Operation* response) override;
  grpc::ServerUnaryReactor* ListObjects(grpc::CallbackServerContext* ctx,
                                        const v1::ListObjectsRequest* request,
                                        v1::ListObjectsResponse* response) override;
  grpc::ServerUnaryReactor* GetObject(grpc::CallbackServerContext* ctx,
                                      const v1::GetObjectRequest* request,
                                      v1::Object* response) override;
  grpc::ServerUnaryReactor* DeleteObject(grpc::CallbackServerContext* ctx,
                                         const v1::DeleteObjectRequest* request,
                                         v1::DeleteObjectResponse* response) override;
  grpc::ServerUnaryReactor* BuildClassifier(grpc::CallbackServerContext* ctx,
                                            const v1::BuildClassifierRequest* request,
                                            v1::Operation* response) override;
  grpc::ServerUnaryReactor* GetClassifier(grpc::CallbackServerContext* ctx,
                                          const v1::GetClassifierRequest* request,
                                          v1::Classifier* response) override;
  grpc::ServerUnaryReactor* ClassifyImage(grpc::CallbackServerContext* ctx,
                                          const v1::ClassifyImageRequest* request,
                                          v1::ClassifyImageResponse* response) override;
  grpc::ServerUnaryReactor* GetOperation(grpc::CallbackServerContext* ctx,
                                         const v1::GetOperationRequest* request,
                                         v1::Operation* response) override;
  grpc::ServerUnaryReactor* WaitOperation(grpc::CallbackServerContext* ctx,
                                          const v1::WaitOperationRequest* request,
                                          v1::Operation* response) override;

 private:
  absl::Status Allow(grpc::CallbackServerContext* ctx, auth::Role needed) const;

  ObjectService* const core_;
  const auth::Authorizer* const auth_;
};

}  // namespace skimap::server

#endif  // SERVER_GRPC_OBJECT_GRPC_SERVICE_H_
