// A client that knows nothing of skimap's .proto files, like grpcurl: it lists the
// services of a real skimapd through server reflection (v1alpha, what gRPC 1.51 serves),
// fetches MapService's file descriptors, builds the request messages dynamically and calls
// the service through a generic stub. And the standard health service answers per service.
//
// This binary links the reflection and health protos generated from Debian's grpc-proto
// and neither skimap's protos nor grpc++_reflection (their descriptors would clash).
#include <google/protobuf/descriptor.h>
#include <google/protobuf/descriptor.pb.h>
#include <google/protobuf/dynamic_message.h>
#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <map>
#include <set>
#include <string>
#include <thread>

#include "grpc/health/v1/health.grpc.pb.h"
#include "grpc/reflection/v1alpha/reflection.grpc.pb.h"
#include "tests/common/free_port.h"
#include "tests/common/spawn.h"

namespace skimap::testing {
namespace {

namespace refl = grpc::reflection::v1alpha;
namespace pb = google::protobuf;

class ReflectionTest : public ::testing::Test {
 protected:
  void SetUp() override {
    address_ = "127.0.0.1:" + std::to_string(FreePort());
    dir_ = std::filesystem::temp_directory_path() / ("skimap_refl_" + std::to_string(getpid()));
    pid_ = SpawnProcess({SKIMAPD_PATH, "--address=" + address_, "--data_dir=" + dir_.string(),
                         "--worker_threads=1", "--http_address="});
    ASSERT_GE(pid_, 0);
    channel_ = grpc::CreateChannel(address_, grpc::InsecureChannelCredentials());
    ASSERT_TRUE(
        channel_->WaitForConnected(std::chrono::system_clock::now() + std::chrono::seconds(20)));
  }
  void TearDown() override {
    kill(pid_, SIGTERM);
    waitpid(pid_, nullptr, 0);
    std::filesystem::remove_all(dir_);
  }

  // One request on a fresh reflection stream.
  refl::ServerReflectionResponse Ask(const refl::ServerReflectionRequest& request) {
    auto stub = refl::ServerReflection::NewStub(channel_);
    grpc::ClientContext ctx;
    auto stream = stub->ServerReflectionInfo(&ctx);
    EXPECT_TRUE(stream->Write(request));
    stream->WritesDone();
    refl::ServerReflectionResponse response;
    EXPECT_TRUE(stream->Read(&response));
    EXPECT_TRUE(stream->Finish().ok());
    return response;
  }

  // Adds the file descriptors that define `symbol` (and what they import) to pool_.
  void LoadSymbol(const std::string& symbol) {
    refl::ServerReflectionRequest request;
    request.set_file_containing_symbol(symbol);
    const refl::ServerReflectionResponse response = Ask(request);
    ASSERT_TRUE(response.has_file_descriptor_response())
        << symbol << ": " << response.error_response().error_message();
    std::map<std::string, pb::FileDescriptorProto> files;
    for (const std::string& bytes : response.file_descriptor_response().file_descriptor_proto()) {
      pb::FileDescriptorProto file;
      ASSERT_TRUE(file.ParseFromString(bytes));
      files[file.name()] = file;
    }
    // Build in dependency order; ask for any dependency the server did not send.
    std::function<void(const std::string&)> build = [&](const std::string& name) {
      if (pool_.FindFileByName(name) != nullptr) return;
      if (!files.contains(name)) {
        refl::ServerReflectionRequest by_name;
        by_name.set_file_by_filename(name);
        const refl::ServerReflectionResponse r = Ask(by_name);
        ASSERT_TRUE(r.has_file_descriptor_response()) << name;
        for (const std::string& bytes : r.file_descriptor_response().file_descriptor_proto()) {
          pb::FileDescriptorProto file;
          ASSERT_TRUE(file.ParseFromString(bytes));
          files[file.name()] = file;
        }
        ASSERT_TRUE(files.contains(name)) << name;
      }
      for (const std::string& dep : files[name].dependency()) build(dep);
      ASSERT_NE(pool_.BuildFile(files[name]), nullptr) << name;
    };
    for (const auto& [name, file] : std::map(files)) build(name);
  }

  // Calls /service/method with `request` through a generic stub; returns the status and
  // fills *response.
  grpc::Status Call(const pb::MethodDescriptor* method, const pb::Message& request,
                    pb::Message* response) {
    grpc::GenericStub stub(channel_);
    grpc::CompletionQueue cq;
    grpc::ClientContext ctx;
    std::string bytes;
    request.SerializeToString(&bytes);
    grpc::Slice slice(bytes);
    grpc::ByteBuffer in(&slice, 1), out;
    auto call = stub.PrepareUnaryCall(
        &ctx, "/" + method->service()->full_name() + "/" + method->name(), in, &cq);
    call->StartCall();
    grpc::Status status;
    call->Finish(&out, &status, reinterpret_cast<void*>(1));
    void* tag = nullptr;
    bool ok = false;
    EXPECT_TRUE(cq.Next(&tag, &ok));
    std::vector<grpc::Slice> slices;
    if (status.ok() && out.Dump(&slices).ok()) {
      std::string got;
      for (const grpc::Slice& s : slices)
        got.append(reinterpret_cast<const char*>(s.begin()), s.size());
      EXPECT_TRUE(response->ParseFromString(got));
    }
    return status;
  }

  std::string address_;
  std::filesystem::path dir_;
  pid_t pid_ = -1;
  std::shared_ptr<grpc::Channel> channel_;
  pb::DescriptorPool pool_;
};

TEST_F(ReflectionTest, ListsAndDescribesEveryServiceSoAGenericClientCanCallThem) {
  refl::ServerReflectionRequest list;
  list.set_list_services("*");
  std::set<std::string> services;
  const refl::ServerReflectionResponse listed = Ask(list);
  for (const auto& s : listed.list_services_response().service()) services.insert(s.name());
  EXPECT_TRUE(services.contains("skimap.v1.MapService"));
  EXPECT_TRUE(services.contains("skimap.v1.ObjectService"));
  EXPECT_TRUE(services.contains("grpc.health.v1.Health"));

  LoadSymbol("skimap.v1.MapService");
  LoadSymbol("skimap.v1.ObjectService");
  const pb::ServiceDescriptor* maps = pool_.FindServiceByName("skimap.v1.MapService");
  ASSERT_NE(maps, nullptr);
  EXPECT_NE(pool_.FindServiceByName("skimap.v1.ObjectService"), nullptr);
  for (const char* rpc :
       {"CreateMap", "GetMap", "StreamFrames", "GetOccupancyGrid", "RadiusSearch"}) {
    EXPECT_NE(maps->FindMethodByName(rpc), nullptr) << rpc;
  }
  // The health service is described too (grpcurl's `describe grpc.health.v1.Health`).
  LoadSymbol("grpc.health.v1.Health");
  const pb::ServiceDescriptor* health = pool_.FindServiceByName("grpc.health.v1.Health");
  ASSERT_NE(health, nullptr);
  EXPECT_NE(health->FindMethodByName("Check"), nullptr);
  EXPECT_NE(health->FindMethodByName("Watch"), nullptr);

  // CreateMap and GetMap with messages built from the fetched descriptors only.
  pb::DynamicMessageFactory factory(&pool_);
  const pb::MethodDescriptor* create = maps->FindMethodByName("CreateMap");
  std::unique_ptr<pb::Message> request(factory.GetPrototype(create->input_type())->New());
  request->GetReflection()->SetString(request.get(),
                                      create->input_type()->FindFieldByName("map_id"), "reflected");
  std::unique_ptr<pb::Message> map(factory.GetPrototype(create->output_type())->New());
  grpc::Status status = Call(create, *request, map.get());
  ASSERT_TRUE(status.ok()) << status.error_message();
  const pb::FieldDescriptor* name = create->output_type()->FindFieldByName("name");
  EXPECT_EQ(map->GetReflection()->GetString(*map, name), "maps/reflected");

  const pb::MethodDescriptor* get = maps->FindMethodByName("GetMap");
  std::unique_ptr<pb::Message> get_request(factory.GetPrototype(get->input_type())->New());
  get_request->GetReflection()->SetString(get_request.get(),
                                          get->input_type()->FindFieldByName("name"), "maps/nope");
  std::unique_ptr<pb::Message> none(factory.GetPrototype(get->output_type())->New());
  EXPECT_EQ(Call(get, *get_request, none.get()).error_code(), grpc::StatusCode::NOT_FOUND);
}

TEST_F(ReflectionTest, HealthAnswersForTheServerAndEachService) {
  auto health = grpc::health::v1::Health::NewStub(channel_);
  auto check = [&](const std::string& service) {
    grpc::ClientContext ctx;
    grpc::health::v1::HealthCheckRequest request;
    request.set_service(service);
    grpc::health::v1::HealthCheckResponse response;
    const grpc::Status status = health->Check(&ctx, request, &response);
    return std::pair(status.error_code(), response.status());
  };
  using grpc::health::v1::HealthCheckResponse;
  for (const char* service : {"", "skimap.v1.MapService", "skimap.v1.ObjectService"}) {
    EXPECT_EQ(check(service), std::pair(grpc::StatusCode::OK, HealthCheckResponse::SERVING))
        << service;
  }
  EXPECT_EQ(check("skimap.v1.NoSuchService").first, grpc::StatusCode::NOT_FOUND);
}

}  // namespace
}  // namespace skimap::testing
