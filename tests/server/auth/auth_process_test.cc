// Bearer-token authentication against a real skimapd (--auth_tokens_file), on gRPC and
// REST: every refusal path (no token, unknown token, role too low, map outside the scope),
// what stays public (health), SIGHUP reloads (a token removed, a token added, a broken
// file that keeps the previous tokens and logs no secret), and binding beyond loopback.
#include <gmock/gmock.h>
#include <google/protobuf/descriptor.h>
#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>

#include "absl/strings/str_cat.h"
#include "client/map_client.h"
#include "grpc/health/v1/health.grpc.pb.h"
#include "server/core/auth/access.h"
#include "skimap/v1/fleet.pb.h"
#include "skimap/v1/map_service.pb.h"
#include "skimap/v1/objects.pb.h"
#include "tests/common/skimapd_process.h"
#include "tests/server/http/http_client.h"

namespace skimap::testing {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

constexpr char kAdmin[] = "admin-0f1e2d3c4b5a69788796";
constexpr char kRobot[] = "robot-kitchen-a1b2c3d4e5f6";  // write, maps kitchen only
constexpr char kViewer[] = "viewer-99887766554433221100";
constexpr char kWriter[] = "writer-1a2b3c4d5e6f7a8b9c0d";  // write, every map
constexpr char kLater[] = "later-added-5566778899aabb";
constexpr char kJson[] = "application/json";

std::string Tokens(bool with_viewer, bool with_later) {
  std::string text = absl::StrCat("# skimapd tokens\n", kAdmin, " admin\n", kRobot,
                                  " write kitchen\n", kWriter, " write\n");
  if (with_viewer) absl::StrAppend(&text, kViewer, " read\n");
  if (with_later) absl::StrAppend(&text, kLater, " read\n");
  return text;
}

class AuthProcessTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() / absl::StrCat("skimapd_auth_", getpid());
    std::filesystem::create_directories(dir_);
    tokens_ = dir_ / "tokens";
    log_ = dir_ / "skimapd.log";
    WriteTokens(Tokens(/*with_viewer=*/true, /*with_later=*/false));
    server_ = std::make_unique<SkimapdProcess>(
        SKIMAPD_PATH,
        std::vector<std::string>{"--worker_threads=1", "--auth_tokens_file=" + tokens_.string()});
    server_->set_log_file(log_.string());
    ASSERT_TRUE(server_->Start().ok());
    http_ = std::make_unique<httplib::Client>("127.0.0.1", server_->http_port());
  }
  void TearDown() override {
    server_.reset();
    std::filesystem::remove_all(dir_);
  }

  void WriteTokens(const std::string& text) {
    const std::filesystem::path tmp = tokens_.string() + ".new";
    std::ofstream(tmp, std::ios::trunc) << text;
    std::filesystem::rename(tmp, tokens_);  // atomically, as an operator would
  }
  std::string Log() const {
    std::ifstream in(log_);
    std::stringstream text;
    text << in.rdbuf();
    return text.str();
  }
  // Waits (up to 10 s) until the log shows `n` SIGHUP lines.
  void WaitForReloads(int n) {
    for (int i = 0; i < 1000; ++i) {
      const std::string log = Log();
      int count = 0;
      for (size_t at = log.find("SIGHUP"); at != std::string::npos;
           at = log.find("SIGHUP", at + 1)) {
        ++count;
      }
      if (count >= n) return;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    FAIL() << "skimapd did not log " << n << " reloads:\n" << Log();
  }

  std::unique_ptr<client::MapClient> Client(const std::string& token) {
    return client::MapClient::Connect(server_->address(), {.connection = {.token = token}});
  }
  httplib::Headers Bearer(const std::string& token) {
    return {{"Authorization", "Bearer " + token}};
  }
  absl::Status CreateMap(const std::string& token, const std::string& id) {
    v1::CreateMapRequest request;
    request.set_map_id(id);
    return Client(token)->CreateMap(request).status();
  }

  std::filesystem::path dir_, tokens_, log_;
  std::unique_ptr<SkimapdProcess> server_;
  std::unique_ptr<httplib::Client> http_;
};

TEST_F(AuthProcessTest, GrpcRefusesMissingAndUnknownTokensWithoutEchoingThem) {
  const absl::Status none = Client("")->GetMap("maps/kitchen").status();
  EXPECT_EQ(none.code(), absl::StatusCode::kUnauthenticated);
  EXPECT_THAT(none.message(), HasSubstr("missing bearer token"));
  const std::string wrong = "not-a-token-of-this-server-42";
  const absl::Status unknown = Client(wrong)->ListAllMaps().status();
  EXPECT_EQ(unknown.code(), absl::StatusCode::kUnauthenticated);
  EXPECT_THAT(unknown.message(), HasSubstr("unknown bearer token"));
  EXPECT_THAT(unknown.message(), Not(HasSubstr(wrong)));
  // Streams too: StreamFrames is refused before any frame is read.
  std::unique_ptr<client::FrameStream> stream = Client("")->OpenFrameStream({});
  EXPECT_EQ(stream->Finish().status().code(), absl::StatusCode::kUnauthenticated);
  EXPECT_THAT(Log(), Not(HasSubstr(wrong)));
}

TEST_F(AuthProcessTest, GrpcRolesAndMapScopes) {
  // read < write < admin.
  EXPECT_EQ(CreateMap(kViewer, "kitchen").code(), absl::StatusCode::kPermissionDenied);
  ASSERT_TRUE(CreateMap(kRobot, "kitchen").ok());
  ASSERT_TRUE(CreateMap(kAdmin, "hall").ok());
  EXPECT_TRUE(Client(kViewer)->GetMap("maps/kitchen").ok());
  const absl::Status delete_by_robot = Client(kRobot)->DeleteMap("maps/kitchen");
  EXPECT_EQ(delete_by_robot.code(), absl::StatusCode::kPermissionDenied);
  EXPECT_THAT(delete_by_robot.message(), HasSubstr("needs the admin role"));
  EXPECT_THAT(delete_by_robot.message(), Not(HasSubstr(kRobot)));
  // The robot's token is limited to kitchen: hall is refused, and not listed.
  const absl::Status hall = Client(kRobot)->GetMap("maps/hall").status();
  EXPECT_EQ(hall.code(), absl::StatusCode::kPermissionDenied);
  EXPECT_THAT(hall.message(), HasSubstr("outside its map scope"));
  EXPECT_EQ(CreateMap(kRobot, "lab").code(), absl::StatusCode::kPermissionDenied);
  absl::StatusOr<std::vector<v1::Map>> robot_maps = Client(kRobot)->ListAllMaps();
  ASSERT_TRUE(robot_maps.ok());
  ASSERT_EQ(robot_maps->size(), 1u);
  EXPECT_EQ((*robot_maps)[0].name(), "maps/kitchen");
  EXPECT_EQ(Client(kAdmin)->ListAllMaps()->size(), 2u);
  // A frame for a map outside the scope is acknowledged with PERMISSION_DENIED.
  std::unique_ptr<client::FrameStream> stream = Client(kRobot)->OpenFrameStream({});
  v1::Frame frame;
  frame.set_map("maps/hall");
  frame.set_sequence(1);
  ASSERT_TRUE(stream->Send(frame).ok());
  absl::StatusOr<std::vector<v1::FrameAck>> acks = stream->Finish();
  ASSERT_TRUE(acks.ok()) << acks.status();
  ASSERT_EQ(acks->size(), 1u);
  EXPECT_EQ((*acks)[0].code(), int(absl::StatusCode::kPermissionDenied));
  // Export is admin-only.
  const absl::Status exported = Client(kRobot)->ExportMap(
      [] {
        v1::ExportMapRequest r;
        r.set_name("maps/kitchen");
        return r;
      }(),
      [](std::string_view) { return absl::OkStatus(); });
  EXPECT_EQ(exported.code(), absl::StatusCode::kPermissionDenied);
  EXPECT_TRUE(Client(kAdmin)->DeleteMap("maps/kitchen").ok());
}

// Whether /`method`, called with one empty request message and `token` (a generic call: the
// handler's own access check runs before the request is looked at), is refused for the
// token's role ("this call needs the admin role; ..."). Other refusals (a server without a
// dataset root, say) do not count.
bool RefusedForRole(const std::shared_ptr<grpc::Channel>& channel, const std::string& method,
                    const std::string& token) {
  grpc::GenericStub stub(channel);
  grpc::CompletionQueue cq;
  grpc::ClientContext ctx;
  ctx.AddMetadata("authorization", "Bearer " + token);
  ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(20));
  grpc::Slice empty("");
  grpc::ByteBuffer in(&empty, 1), out;
  auto call = stub.PrepareUnaryCall(&ctx, method, in, &cq);
  call->StartCall();
  grpc::Status status;
  call->Finish(&out, &status, reinterpret_cast<void*>(1));
  void* tag = nullptr;
  bool ok = false;
  EXPECT_TRUE(cq.Next(&tag, &ok));
  EXPECT_NE(status.error_code(), grpc::StatusCode::UNAUTHENTICATED) << method;
  EXPECT_NE(status.error_code(), grpc::StatusCode::UNIMPLEMENTED) << method;
  return status.error_code() == grpc::StatusCode::PERMISSION_DENIED &&
         status.error_message().find(" role") != std::string::npos;
}

// Each gRPC handler asks the role the access table declares for its own method: the lowest
// token that gets past the access check (read, then write, then admin) has exactly that
// role. A handler that named another method's role, or a misspelt one (which needs admin),
// fails here.
TEST_F(AuthProcessTest, EveryGrpcHandlerAsksTheRoleOfItsAccessTableEntry) {
  auto channel = grpc::CreateChannel(server_->address(), grpc::InsecureChannelCredentials());
  int checked = 0;
  for (const char* service : {"skimap.v1.MapService", "skimap.v1.ObjectService"}) {
    const google::protobuf::ServiceDescriptor* s =
        google::protobuf::DescriptorPool::generated_pool()->FindServiceByName(service);
    ASSERT_NE(s, nullptr) << service;
    for (int i = 0; i < s->method_count(); ++i) {
      const std::string method = absl::StrCat("/", service, "/", s->method(i)->name());
      const std::string entry = absl::StrCat(s->name(), "/", s->method(i)->name());
      ASSERT_FALSE(RefusedForRole(channel, method, kAdmin)) << method;
      server::auth::Role lowest = server::auth::Role::kAdmin;
      if (!RefusedForRole(channel, method, kViewer)) {
        lowest = server::auth::Role::kRead;
      } else if (!RefusedForRole(channel, method, kWriter)) {
        lowest = server::auth::Role::kWrite;
      }
      EXPECT_EQ(lowest, server::auth::MethodRole(entry))
          << method << " lets " << server::auth::RoleName(lowest) << " in; its entry says "
          << server::auth::RoleName(server::auth::MethodRole(entry));
      ++checked;
    }
  }
  EXPECT_EQ(checked, 29);  // 18 MapService + 11 ObjectService methods
}

TEST_F(AuthProcessTest, HealthNeedsNoToken) {
  auto channel = grpc::CreateChannel(server_->address(), grpc::InsecureChannelCredentials());
  auto health = grpc::health::v1::Health::NewStub(channel);
  grpc::ClientContext ctx;
  grpc::health::v1::HealthCheckRequest request;
  grpc::health::v1::HealthCheckResponse response;
  ASSERT_TRUE(health->Check(&ctx, request, &response).ok());
  EXPECT_EQ(response.status(), grpc::health::v1::HealthCheckResponse::SERVING);
  httplib::Result healthz = http_->Get("/healthz");
  ASSERT_TRUE(healthz);
  EXPECT_EQ(healthz->status, 200);
  EXPECT_EQ(http_->Get("/v1/openapi.json")->status, 200);
}

TEST_F(AuthProcessTest, RestAnswers401And403) {
  httplib::Result none = http_->Get("/v1/maps");
  ASSERT_TRUE(none);
  EXPECT_EQ(none->status, 401);
  EXPECT_EQ(none->get_header_value("WWW-Authenticate"), "Bearer realm=\"skimapd\"");
  EXPECT_THAT(none->body, HasSubstr("missing bearer token"));
  const std::string wrong = "rest-wrong-token-1234567890";
  httplib::Result unknown = http_->Get("/v1/maps", Bearer(wrong));
  EXPECT_EQ(unknown->status, 401);
  EXPECT_THAT(unknown->body, Not(HasSubstr(wrong)));
  httplib::Result basic = http_->Get("/v1/maps", {{"Authorization", "Basic YTpi"}});
  EXPECT_EQ(basic->status, 401);
  // Roles.
  EXPECT_EQ(http_->Post("/v1/maps", Bearer(kViewer), R"({"mapId": "kitchen"})", kJson)->status,
            403);
  EXPECT_EQ(http_->Post("/v1/maps", Bearer(kRobot), R"({"mapId": "kitchen"})", kJson)->status, 200);
  EXPECT_EQ(http_->Post("/v1/maps", Bearer(kAdmin), R"({"mapId": "hall"})", kJson)->status, 200);
  EXPECT_EQ(http_->Get("/v1/maps/kitchen", Bearer(kViewer))->status, 200);
  httplib::Result deleted = http_->Delete("/v1/maps/kitchen", Bearer(kRobot));
  EXPECT_EQ(deleted->status, 403);
  EXPECT_THAT(deleted->body, HasSubstr("needs the admin role"));
  // Scope: the map in the path and the map in the body.
  EXPECT_EQ(http_->Get("/v1/maps/hall", Bearer(kRobot))->status, 403);
  EXPECT_EQ(http_->Get("/v1/maps/hall/occupancyGrid", Bearer(kRobot))->status, 403);
  EXPECT_EQ(http_->Post("/v1/maps", Bearer(kRobot), R"({"mapId": "lab"})", kJson)->status, 403);
  httplib::Result listed = http_->Get("/v1/maps", Bearer(kRobot));
  ASSERT_EQ(listed->status, 200);
  EXPECT_THAT(listed->body, HasSubstr("maps/kitchen"));
  EXPECT_THAT(listed->body, Not(HasSubstr("maps/hall")));
  EXPECT_EQ(http_->Delete("/v1/maps/hall", Bearer(kAdmin))->status, 200);
  EXPECT_THAT(Log(), Not(HasSubstr(wrong)));
}

TEST_F(AuthProcessTest, SighupReloadsTokensAndABrokenFileKeepsThePreviousOnes) {
  ASSERT_TRUE(Client(kViewer)->ListAllMaps().ok());
  EXPECT_EQ(Client(kLater)->ListAllMaps().status().code(), absl::StatusCode::kUnauthenticated);
  // The viewer's token removed, a new one added.
  WriteTokens(Tokens(/*with_viewer=*/false, /*with_later=*/true));
  server_->Signal(SIGHUP);
  WaitForReloads(1);
  EXPECT_EQ(Client(kViewer)->ListAllMaps().status().code(), absl::StatusCode::kUnauthenticated);
  EXPECT_EQ(http_->Get("/v1/maps", Bearer(kViewer))->status, 401);
  EXPECT_TRUE(Client(kLater)->ListAllMaps().ok());
  EXPECT_EQ(http_->Get("/v1/maps", Bearer(kLater))->status, 200);
  // A broken file (an unknown role on line 3): the previous tokens stay, the log says why.
  const std::string leaked = "would-be-token-abcdefghijkl";
  WriteTokens(absl::StrCat(kAdmin, " admin\n\n", leaked, " superuser\n"));
  server_->Signal(SIGHUP);
  WaitForReloads(2);
  EXPECT_TRUE(Client(kLater)->ListAllMaps().ok());
  EXPECT_EQ(http_->Get("/v1/maps", Bearer(kLater))->status, 200);
  EXPECT_TRUE(Client(kRobot)->GetMap("maps/kitchen").status().code() ==
              absl::StatusCode::kNotFound);
  EXPECT_EQ(Client(leaked)->ListAllMaps().status().code(), absl::StatusCode::kUnauthenticated);
  const std::string log = Log();
  EXPECT_THAT(log, HasSubstr("line 3: role \"superuser\""));
  EXPECT_THAT(log, HasSubstr("the previous tokens stay"));
  for (const char* secret : {kAdmin, kRobot, kViewer, kLater}) {
    EXPECT_THAT(log, Not(HasSubstr(secret)));
  }
  EXPECT_THAT(log, Not(HasSubstr(leaked)));
  EXPECT_TRUE(server_->Running());
}

// Secure default: beyond loopback needs --insecure or tokens; with tokens it starts.
TEST(AuthBindTest, TokensAllowEveryInterfaceWithoutInsecure) {
  const std::filesystem::path tokens =
      std::filesystem::temp_directory_path() / absl::StrCat("skimapd_auth_bind_", getpid());
  std::ofstream(tokens) << kAdmin << " admin\n";
  SkimapdProcess server(SKIMAPD_PATH, {"--auth_tokens_file=" + tokens.string()});
  ASSERT_TRUE(server.StartOn("0.0.0.0").ok());
  auto client = client::MapClient::Connect(server.address(), {.connection = {.token = kAdmin}});
  EXPECT_TRUE(client->ListAllMaps().ok());
  EXPECT_EQ(client::MapClient::Connect(server.address())->ListAllMaps().status().code(),
            absl::StatusCode::kUnauthenticated);
  std::filesystem::remove(tokens);
}

TEST(AuthBindTest, AnUnreadableOrBrokenTokenFileStopsTheStart) {
  const std::filesystem::path tokens =
      std::filesystem::temp_directory_path() / absl::StrCat("skimapd_auth_broken_", getpid());
  std::ofstream(tokens) << "short admin\n";
  const std::string dir = tokens.string() + ".data";
  for (const std::string& file : {tokens.string(), tokens.string() + ".missing"}) {
    const std::string command = absl::StrCat(SKIMAPD_PATH, " --data_dir=", dir,
                                             " --http_address= --auth_tokens_file=", file, " 2>&1");
    FILE* out = popen(command.c_str(), "r");
    std::string text;
    char buf[512];
    while (fgets(buf, sizeof buf, out) != nullptr) text += buf;
    const int status = pclose(out);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 1) << text;
    EXPECT_THAT(text, HasSubstr("--auth_tokens_file " + file)) << text;
  }
  std::filesystem::remove(tokens);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace skimap::testing
