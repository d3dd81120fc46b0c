#include "client/object_client.h"

#include <fstream>

#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "client/map_client.h"  // FromGrpcStatus, MakeChannel

namespace skimap::client {

std::unique_ptr<ObjectClient> ObjectClient::Connect(const std::string& target,
                                                    const Options& options) {
  return std::unique_ptr<ObjectClient>(new ObjectClient(
      MakeChannel(target, options.max_message_bytes, options.connection), options));
}

ObjectClient::ObjectClient(std::shared_ptr<grpc::Channel> channel, const Options& options)
    : options_(options),
      channel_(std::move(channel)),
      stub_(v1::ObjectService::NewStub(channel_)) {}

void ObjectClient::SetDeadline(grpc::ClientContext* ctx, absl::Duration timeout) const {
  ctx->set_deadline(absl::ToChronoTime(absl::Now() + timeout));
}

absl::StatusOr<v1::Object> ObjectClient::TrainObject(const v1::TrainObjectRequest& header,
                                                     const NextFrame& next_frame) {
  grpc::ClientContext ctx;
  SetDeadline(&ctx, options_.train_timeout);
  v1::Object object;
  std::unique_ptr<grpc::ClientWriter<v1::TrainObjectRequest>> writer =
      stub_->TrainObject(&ctx, &object);
  v1::TrainObjectRequest first = header;
  first.clear_frame();
  absl::Status local;
  bool open = writer->Write(first);
  while (open) {
    absl::StatusOr<std::optional<v1::TrainingFrame>> frame = next_frame();
    if (!frame.ok()) {
      local = frame.status();
      ctx.TryCancel();
      break;
    }
    if (!frame->has_value()) break;
    v1::TrainObjectRequest message;
    *message.mutable_frame() = **std::move(frame);
    open = writer->Write(message);  // false: the server already answered (an error)
  }
  writer->WritesDone();
  const grpc::Status s = writer->Finish();
  if (!local.ok()) return local;
  if (!s.ok()) return FromGrpcStatus(s);
  return object;
}

absl::StatusOr<v1::Operation> ObjectClient::AddObjectModel(
    const v1::AddObjectModelRequest& header, const std::vector<ModelFileToSend>& files) {
  grpc::ClientContext ctx;
  SetDeadline(&ctx, options_.train_timeout);
  v1::Operation op;
  std::unique_ptr<grpc::ClientWriter<v1::AddObjectModelRequest>> writer =
      stub_->AddObjectModel(&ctx, &op);
  v1::AddObjectModelRequest first = header;
  first.clear_file();
  absl::Status local;
  bool open = writer->Write(first);
  std::vector<char> buffer(size_t{1} << 20);
  for (size_t i = 0; open && local.ok() && i < files.size(); ++i) {
    std::ifstream in(files[i].path, std::ios::binary);
    if (!in) {
      local = absl::NotFoundError(absl::StrCat(files[i].path, ": cannot read"));
      ctx.TryCancel();
      break;
    }
    bool first_piece = true;
    while (open && (in || first_piece)) {
      in.read(buffer.data(), static_cast<std::streamsize>(buffer.size()));
      const std::streamsize n = in.gcount();
      if (n == 0 && !first_piece) break;
      v1::AddObjectModelRequest message;
      message.mutable_file()->set_name(files[i].name);
      message.mutable_file()->set_data(buffer.data(), static_cast<size_t>(n));
      open = writer->Write(message);  // false: the server already answered (an error)
      first_piece = false;
    }
  }
  writer->WritesDone();
  const grpc::Status s = writer->Finish();
  if (!local.ok()) return local;
  if (!s.ok()) return FromGrpcStatus(s);
  return op;
}

#define SKIMAP_UNARY(Method, Request, Response, request_expr)    \
  grpc::ClientContext ctx;                                       \
  SetDeadline(&ctx, options_.timeout);                           \
  Response response;                                             \
  grpc::Status s = stub_->Method(&ctx, request_expr, &response); \
  if (!s.ok()) return FromGrpcStatus(s);                         \
  return response

absl::StatusOr<v1::Operation> ObjectClient::TrainObjectFromDataset(
    const v1::TrainObjectFromDatasetRequest& request) {
  SKIMAP_UNARY(TrainObjectFromDataset, v1::TrainObjectFromDatasetRequest, v1::Operation, request);
}

absl::StatusOr<v1::ListObjectsResponse> ObjectClient::ListObjects(
    const v1::ListObjectsRequest& request) {
  SKIMAP_UNARY(ListObjects, v1::ListObjectsRequest, v1::ListObjectsResponse, request);
}

absl::StatusOr<std::vector<v1::Object>> ObjectClient::ListAllObjects() {
  std::vector<v1::Object> out;
  v1::ListObjectsRequest request;
  request.set_page_size(1000);
  for (;;) {
    absl::StatusOr<v1::ListObjectsResponse> page = ListObjects(request);
    if (!page.ok()) return page.status();
    for (v1::Object& o : *page->mutable_objects()) out.push_back(std::move(o));
    if (page->next_page_token().empty()) return out;
    request.set_page_token(page->next_page_token());
  }
}

absl::StatusOr<v1::Object> ObjectClient::GetObject(const std::string& name, v1::ObjectView view) {
  v1::GetObjectRequest request;
  request.set_name(name);
  request.set_view(view);
  SKIMAP_UNARY(GetObject, v1::GetObjectRequest, v1::Object, request);
}

absl::Status ObjectClient::DeleteObject(const std::string& name) {
  v1::DeleteObjectRequest request;
  request.set_name(name);
  grpc::ClientContext ctx;
  SetDeadline(&ctx, options_.timeout);
  v1::DeleteObjectResponse response;
  return FromGrpcStatus(stub_->DeleteObject(&ctx, request, &response));
}

absl::StatusOr<v1::Operation> ObjectClient::BuildClassifier(
    const v1::BuildClassifierRequest& request) {
  SKIMAP_UNARY(BuildClassifier, v1::BuildClassifierRequest, v1::Operation, request);
}

absl::StatusOr<v1::Classifier> ObjectClient::GetClassifier() {
  v1::GetClassifierRequest request;
  SKIMAP_UNARY(GetClassifier, v1::GetClassifierRequest, v1::Classifier, request);
}

absl::StatusOr<v1::ClassifyImageResponse> ObjectClient::ClassifyImage(
    const v1::ClassifyImageRequest& request) {
  SKIMAP_UNARY(ClassifyImage, v1::ClassifyImageRequest, v1::ClassifyImageResponse, request);
}

absl::StatusOr<v1::Operation> ObjectClient::GetOperation(const std::string& name) {
  v1::GetOperationRequest request;
  request.set_name(name);
  SKIMAP_UNARY(GetOperation, v1::GetOperationRequest, v1::Operation, request);
}

absl::StatusOr<v1::Operation> ObjectClient::WaitOperation(const std::string& name,
                                                          absl::Duration timeout) {
  v1::WaitOperationRequest request;
  request.set_name(name);
  request.mutable_timeout()->set_seconds(absl::ToInt64Seconds(timeout));
  request.mutable_timeout()->set_nanos(
      static_cast<int32_t>(absl::ToInt64Nanoseconds(timeout % absl::Seconds(1))));
  SKIMAP_UNARY(WaitOperation, v1::WaitOperationRequest, v1::Operation, request);
}

#undef SKIMAP_UNARY

absl::StatusOr<v1::Operation> ObjectClient::WaitDone(
    const std::string& name, const std::function<void(const v1::Operation&)>& on_progress,
    absl::Duration poll) {
  for (;;) {
    absl::StatusOr<v1::Operation> op = WaitOperation(name, poll);
    if (!op.ok()) return op.status();
    if (on_progress) on_progress(*op);
    if (op->done()) {
      if (op->code() != 0) {
        return absl::Status(static_cast<absl::StatusCode>(op->code()), op->message());
      }
      return op;
    }
  }
}

}  // namespace skimap::client
