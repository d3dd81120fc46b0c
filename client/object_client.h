// ObjectClient: the C++ client of skimap.v1.ObjectService (what `skimap objects` uses).
//
//   std::unique_ptr<ObjectClient> client = ObjectClient::Connect("localhost:50051");
//   absl::StatusOr<v1::Object> o = client->TrainObject(header, frames);   // client stream
//   absl::StatusOr<v1::Operation> op = client->BuildClassifier({});
//   op = client->WaitDone(op->name(), [](const v1::Operation& op) { print progress });
//
// Errors come back as absl::Status with the server's code and message; an operation that
// finished with an error is returned as that error by WaitDone.
//
// Thread safety: thread safe (one channel, any number of concurrent calls).
#ifndef CLIENT_OBJECT_CLIENT_H_
#define CLIENT_OBJECT_CLIENT_H_

#include <grpcpp/grpcpp.h>

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "client/channel.h"
#include "skimap/v1/objects.grpc.pb.h"

namespace skimap::client {

class ObjectClient {
 public:
  struct Options {
    int max_message_bytes = 80 << 20;                  // match skimapd's --max_message_mb
    absl::Duration timeout = absl::Seconds(60);        // deadline of each unary call
    absl::Duration train_timeout = absl::Minutes(30);  // deadline of a TrainObject stream
    Connection connection;                             // TLS and the bearer token (channel.h)
  };
  // Creates a channel to `target` (host:port); does not wait for the server.
  static std::unique_ptr<ObjectClient> Connect(const std::string& target, const Options& options);
  static std::unique_ptr<ObjectClient> Connect(const std::string& target) {
    return Connect(target, Options{});
  }

  // Streams `header` (obj_id, display_name, params; its frame is ignored) and then one
  // message per frame returned by next_frame until it returns nullopt (or an error, which
  // cancels the call and is returned). The server answers once the object is stored.
  using NextFrame = std::function<absl::StatusOr<std::optional<v1::TrainingFrame>>()>;
  absl::StatusOr<v1::Object> TrainObject(const v1::TrainObjectRequest& header,
                                         const NextFrame& next_frame);
  absl::StatusOr<v1::Operation> TrainObjectFromDataset(
      const v1::TrainObjectFromDatasetRequest& request);
  // Streams `header` (obj_id, display_name, model, views, params) and then each file, read
  // from its local path in 1 MiB pieces under its upload name. Answers the operation that
  // renders and trains (wait on it with WaitDone). NotFound naming a file that cannot be
  // read.
  struct ModelFileToSend {
    std::string name;  // as the server will know it, e.g. "textures/wood.png"
    std::string path;  // on this machine
  };
  absl::StatusOr<v1::Operation> AddObjectModel(const v1::AddObjectModelRequest& header,
                                               const std::vector<ModelFileToSend>& files);
  absl::StatusOr<v1::ListObjectsResponse> ListObjects(const v1::ListObjectsRequest& request);
  // Every object, following page tokens.
  absl::StatusOr<std::vector<v1::Object>> ListAllObjects();
  absl::StatusOr<v1::Object> GetObject(const std::string& name,
                                       v1::ObjectView view = v1::OBJECT_VIEW_BASIC);
  absl::Status DeleteObject(const std::string& name);
  absl::StatusOr<v1::Operation> BuildClassifier(const v1::BuildClassifierRequest& request);
  absl::StatusOr<v1::Classifier> GetClassifier();
  absl::StatusOr<v1::ClassifyImageResponse> ClassifyImage(const v1::ClassifyImageRequest& r);
  absl::StatusOr<v1::Operation> GetOperation(const std::string& name);
  // One WaitOperation call (returns when done or after `timeout`).
  absl::StatusOr<v1::Operation> WaitOperation(const std::string& name, absl::Duration timeout);
  // Loops on WaitOperation (`poll` each) until done, calling on_progress after each answer;
  // the operation's own error if it failed.
  absl::StatusOr<v1::Operation> WaitDone(
      const std::string& name, const std::function<void(const v1::Operation&)>& on_progress,
      absl::Duration poll = absl::Seconds(1));

  v1::ObjectService::Stub& stub() { return *stub_; }

 private:
  ObjectClient(std::shared_ptr<grpc::Channel> channel, const Options& options);
  void SetDeadline(grpc::ClientContext* ctx, absl::Duration timeout) const;

  const Options options_;
  std::shared_ptr<grpc::Channel> channel_;
  std::unique_ptr<v1::ObjectService::Stub> stub_;
};

}  // namespace skimap::client

#endif  // CLIENT_OBJECT_CLIENT_H_
