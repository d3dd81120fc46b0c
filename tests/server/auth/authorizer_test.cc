// The token file, grants and the Authorizer (server/core/auth/), and the access table
// (server/core/auth/access.cc) against the API's methods and the routes skimapd serves.
#include "server/core/auth/authorizer.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <string>

#include "absl/strings/str_cat.h"
#include "google/protobuf/descriptor.h"
#include "server/app/server.h"
#include "server/core/auth/access.h"
#include "server/core/auth/token_file.h"
#include "skimap/v1/fleet.pb.h"
#include "skimap/v1/map_service.pb.h"
#include "skimap/v1/objects.pb.h"

namespace skimap::server::auth {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

constexpr char kAdmin[] = "admin-token-0123456789";
constexpr char kRobot[] = "robot-token-0123456789";
constexpr char kViewer[] = "viewer-token-012345678";

std::string TokenText() {
  return absl::StrCat("# tokens\n\n", kAdmin, "  admin\n", kRobot, "\twrite kitchen,hall\n",
                      kViewer, " read *\n");
}

TEST(TokenFileTest, ParsesRolesAndScopes) {
  absl::StatusOr<std::vector<TokenEntry>> entries = ParseTokenFile(TokenText());
  ASSERT_TRUE(entries.ok()) << entries.status();
  ASSERT_EQ(entries->size(), 3u);
  EXPECT_EQ((*entries)[0].grant.role, Role::kAdmin);
  EXPECT_FALSE((*entries)[0].grant.Scoped());
  EXPECT_EQ((*entries)[0].grant.label, "line 3");
  EXPECT_EQ((*entries)[1].grant.role, Role::kWrite);
  EXPECT_THAT((*entries)[1].grant.maps, ::testing::ElementsAre("kitchen", "hall"));
  EXPECT_EQ((*entries)[2].grant.role, Role::kRead);
  EXPECT_FALSE((*entries)[2].grant.Scoped());
  EXPECT_EQ((*entries)[1].digest, DigestToken(kRobot));
}

TEST(TokenFileTest, ErrorsNameTheLineAndNeverTheToken) {
  const std::string secret = "very-secret-token-but-bad";
  for (const auto& [text, expected] : std::vector<std::pair<std::string, std::string>>{
           {absl::StrCat(secret, " root\n"), "line 1: role \"root\""},
           {absl::StrCat("\n", secret, "\n"), "line 2: expected <token> <role>"},
           {"short admin\n", "line 1: the token must have 16 to 256 characters, it has 5"},
           {absl::StrCat(secret, " read a/b\n"), "line 1: map scope"},
           {absl::StrCat(secret, " read\n", secret, " admin\n"),
            "line 2: the same token as line 1"},
           {"# nothing\n", "no token in the file"}}) {
    absl::StatusOr<std::vector<TokenEntry>> entries = ParseTokenFile(text);
    ASSERT_FALSE(entries.ok()) << text;
    EXPECT_EQ(entries.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_THAT(entries.status().message(), HasSubstr(expected));
    EXPECT_THAT(entries.status().message(), Not(HasSubstr(secret)));
  }
}

TEST(GrantTest, RolesAreOrderedAndScopesNameMaps) {
  const Grant writer{.role = Role::kWrite, .maps = {"kitchen"}, .label = "line 1"};
  EXPECT_TRUE(writer.Check(Role::kRead).ok());
  EXPECT_TRUE(writer.Check(Role::kWrite).ok());
  EXPECT_EQ(writer.Check(Role::kAdmin).code(), absl::StatusCode::kPermissionDenied);
  EXPECT_THAT(writer.Check(Role::kAdmin).message(), HasSubstr("needs the admin role"));
  EXPECT_TRUE(writer.CheckMap(Role::kWrite, "maps/kitchen").ok());
  EXPECT_TRUE(writer.CheckMap(Role::kRead, "maps/kitchen/instances/7").ok());
  EXPECT_EQ(writer.CheckMap(Role::kRead, "maps/hall").code(), absl::StatusCode::kPermissionDenied);
  EXPECT_EQ(writer.CheckMap(Role::kRead, "maps/kitchenette").code(),
            absl::StatusCode::kPermissionDenied);
  EXPECT_EQ(writer.CheckMap(Role::kRead, "").code(), absl::StatusCode::kPermissionDenied);
  EXPECT_TRUE(Grant::Everything().CheckMap(Role::kAdmin, "maps/any").ok());
}

class AuthorizerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    path_ = std::filesystem::temp_directory_path() / absl::StrCat("authorizer_test_", getpid());
    Write(TokenText());
    absl::StatusOr<std::unique_ptr<Authorizer>> auth = Authorizer::Open(path_);
    ASSERT_TRUE(auth.ok()) << auth.status();
    auth_ = *std::move(auth);
  }
  void TearDown() override { std::filesystem::remove(path_); }
  void Write(const std::string& text) { std::ofstream(path_, std::ios::trunc) << text; }

  std::string path_;
  std::unique_ptr<Authorizer> auth_;
};

TEST_F(AuthorizerTest, MissingMalformedAndUnknownTokensAreUnauthenticated) {
  for (const std::string& header : std::vector<std::string>{
           "", "Basic YWRtaW46YWRtaW4=", "Bearer", "Bearer nope-not-a-known-token",
           absl::StrCat("Bearer ", kAdmin, "x"),
           absl::StrCat("Bearer ", std::string(kAdmin, 10))}) {
    absl::StatusOr<Grant> grant = auth_->Authenticate(header);
    ASSERT_FALSE(grant.ok()) << header;
    EXPECT_EQ(grant.status().code(), absl::StatusCode::kUnauthenticated) << header;
    EXPECT_THAT(grant.status().message(), Not(HasSubstr("nope")));
    EXPECT_THAT(grant.status().message(), Not(HasSubstr(std::string(kAdmin, 10))));
  }
  EXPECT_THAT(auth_->Authenticate("").status().message(), HasSubstr("missing bearer token"));
  EXPECT_THAT(auth_->Authenticate("Bearer nope-not-a-known-token").status().message(),
              HasSubstr("unknown bearer token"));
}

TEST_F(AuthorizerTest, KnownTokensGetTheirGrantWhateverTheSchemeCase) {
  absl::StatusOr<Grant> admin = auth_->Authenticate(absl::StrCat("bearer ", kAdmin));
  ASSERT_TRUE(admin.ok());
  EXPECT_EQ(admin->role, Role::kAdmin);
  EXPECT_TRUE(auth_->AuthorizeMap(absl::StrCat("Bearer ", kRobot), Role::kWrite, "maps/hall").ok());
  EXPECT_EQ(auth_->AuthorizeMap(absl::StrCat("Bearer ", kRobot), Role::kWrite, "maps/lab")
                .status()
                .code(),
            absl::StatusCode::kPermissionDenied);
  EXPECT_EQ(auth_->Authorize(absl::StrCat("Bearer ", kViewer), Role::kWrite).status().code(),
            absl::StatusCode::kPermissionDenied);
}

TEST_F(AuthorizerTest, ReloadReplacesTokensAndABrokenFileKeepsTheOldOnes) {
  const std::string fresh = "fresh-token-0123456789";
  Write(absl::StrCat(kAdmin, " admin\n", fresh, " read\n"));
  ASSERT_TRUE(auth_->Reload().ok());
  EXPECT_EQ(auth_->size(), 2u);
  EXPECT_TRUE(auth_->Authenticate(absl::StrCat("Bearer ", fresh)).ok());
  EXPECT_FALSE(auth_->Authenticate(absl::StrCat("Bearer ", kRobot)).ok());
  Write(absl::StrCat(kAdmin, " superuser\n"));
  const absl::Status broken = auth_->Reload();
  EXPECT_EQ(broken.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(broken.message(), HasSubstr("line 1"));
  EXPECT_THAT(broken.message(), Not(HasSubstr(kAdmin)));
  EXPECT_TRUE(auth_->Authenticate(absl::StrCat("Bearer ", fresh)).ok());
  std::filesystem::remove(path_);
  EXPECT_EQ(auth_->Reload().code(), absl::StatusCode::kNotFound);
  EXPECT_TRUE(auth_->Authenticate(absl::StrCat("Bearer ", fresh)).ok());
}

// Every route skimapd serves has its row in the access table (a new route must be given a
// role there; unlisted routes need admin).
TEST(RestAccessTest, EveryServedRouteIsListed) {
  Server::Options options;
  options.grpc.address = "127.0.0.1:0";
  options.http.address = "127.0.0.1:0";
  absl::StatusOr<std::unique_ptr<Server>> server = Server::Start(options);
  ASSERT_TRUE(server.ok()) << server.status();
  for (const RestRoute& route : (*server)->http()->routes()) {
    EXPECT_TRUE(RouteListed(route.method, route.path)) << route.method << " " << route.path;
  }
  EXPECT_FALSE(RouteRole("GET", "/healthz").has_value());
  EXPECT_EQ(RouteRole("DELETE", "/v1/maps/{map}"), Role::kAdmin);
  EXPECT_EQ(RouteRole("POST", "/v1/maps/{map}/frames"), Role::kWrite);
  EXPECT_EQ(RouteRole("GET", "/v1/maps/{map}/voxels"), Role::kRead);
  EXPECT_EQ(RouteRole("GET", "/v1/unlisted"), Role::kAdmin);
  EXPECT_FALSE(RouteRole("GET", "/metrics", /*metrics_public=*/true).has_value());
  EXPECT_EQ(RouteRole("GET", "/metrics", /*metrics_public=*/false), Role::kRead);
}

// The access table has exactly one entry per gRPC method of skimap.v1's services, and no
// entry for a method that does not exist; every REST route that serves a gRPC method names
// one of them, and no route is listed twice.
TEST(AccessTableTest, OneEntryPerGrpcMethodAndRoute) {
  std::set<std::string> declared;
  for (const char* service :
       {"skimap.v1.MapService", "skimap.v1.ObjectService", "skimap.v1.FleetService"}) {
    const google::protobuf::ServiceDescriptor* s =
        google::protobuf::DescriptorPool::generated_pool()->FindServiceByName(service);
    ASSERT_NE(s, nullptr) << service;
    for (int i = 0; i < s->method_count(); ++i) {
      declared.insert(absl::StrCat(s->name(), "/", s->method(i)->name()));
    }
  }
  std::map<std::string, int> entries;
  for (const MethodAccess& m : MethodTable()) ++entries[std::string(m.method)];
  for (const std::string& method : declared) {
    EXPECT_EQ(entries[method], 1) << method << " needs exactly one entry in the access table";
  }
  for (const auto& [method, count] : entries) {
    EXPECT_TRUE(declared.count(method))
        << method << " is in the access table but not an API method";
  }
  std::map<std::string, int> routes;
  for (const RouteAccess& r : RouteTable()) {
    EXPECT_EQ(++routes[absl::StrCat(r.http_method, " ", r.path)], 1) << r.path;
    if (!r.serves.empty()) {
      EXPECT_TRUE(declared.count(std::string(r.serves))) << r.path << " serves " << r.serves;
      EXPECT_FALSE(r.role.has_value()) << r.path << ": its role is its method's";
    }
  }
  EXPECT_EQ(MethodRole("MapService/CreateMap"), Role::kWrite);
  EXPECT_EQ(MethodRole("MapService/DeleteMap"), Role::kAdmin);
  EXPECT_EQ(MethodRole("MapService/NoSuchMethod"), Role::kAdmin);
  EXPECT_EQ(RouteRole("POST", "/v1/maps"), MethodRole("MapService/CreateMap"));
}

}  // namespace
}  // namespace skimap::server::auth
