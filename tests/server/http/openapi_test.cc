// The OpenAPI document served at /v1/openapi.json describes exactly the routes the server
// registers: no route undocumented, no documented route missing, every path parameter
// declared, every operation with its success and error responses.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <regex>
#include <set>
#include <string>
#include <utility>

#include "absl/strings/ascii.h"
#include "tests/server/http/rest_fixture.h"

namespace skimap::testing {
namespace {

TEST(OpenApiTest, DocumentsExactlyTheRoutesTheServerRegisters) {
  RestServer rest;
  httplib::Result r = rest.http().Get("/v1/openapi.json");
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200);
  EXPECT_EQ(r->get_header_value("Content-Type"), "application/json");
  const nlohmann::json doc = nlohmann::json::parse(r->body);
  EXPECT_EQ(doc["openapi"].get<std::string>().substr(0, 2), "3.");

  std::set<std::pair<std::string, std::string>> documented;
  for (const auto& [path, item] : doc["paths"].items()) {
    for (const auto& [method, operation] : item.items()) {
      documented.insert({absl::AsciiStrToUpper(method), path});
      EXPECT_TRUE(operation["responses"].contains("200") || operation["responses"].contains("204"))
          << method << " " << path;
      // Every {parameter} of the path is declared as a path parameter.
      std::set<std::string> declared;
      for (const nlohmann::json& p : operation.value("parameters", nlohmann::json::array())) {
        const nlohmann::json& param =
            p.contains("$ref")
                ? doc["components"]["parameters"]
                     [p["$ref"].get<std::string>().substr(sizeof("#/components/parameters/") - 1)]
                : p;
        if (param["in"] == "path") declared.insert(param["name"].get<std::string>());
      }
      std::set<std::string> in_path;
      const std::regex brace("\\{([^}]+)\\}");
      for (std::sregex_iterator it(path.begin(), path.end(), brace), end; it != end; ++it) {
        in_path.insert((*it)[1].str());
      }
      EXPECT_EQ(declared, in_path) << method << " " << path;
    }
  }
  std::set<std::pair<std::string, std::string>> registered;
  ASSERT_NE(rest.server().http(), nullptr);
  for (const server::RestRoute& route : rest.server().http()->routes()) {
    EXPECT_TRUE(registered.insert({route.method, route.path}).second)
        << "registered twice: " << route.method << " " << route.path;
  }
  EXPECT_EQ(documented, registered);
  EXPECT_EQ(registered.size(), 20u);  // with the viewer's trajectory, events, labels; /metrics
}

TEST(OpenApiTest, EveryDocumentedRouteAnswersSomethingOtherThan404Or405ForNoRoute) {
  // Each documented (method, path), with its parameters filled in, reaches its handler:
  // the answer is not the router's "no route" nor 405.
  RestServer rest;
  const nlohmann::json doc = nlohmann::json::parse(rest.http().Get("/v1/openapi.json")->body);
  for (const auto& [path, item] : doc["paths"].items()) {
    const std::string concrete =
        std::regex_replace(path, std::regex("\\{[^}]+\\}"), std::string("p1"));
    for (const auto& [method, operation] : item.items()) {
      httplib::Request request;
      request.method = absl::AsciiStrToUpper(method);
      request.path = concrete;
      if (request.method == "POST") request.body = "{}";
      request.set_header("Content-Type", "application/json");
      httplib::Result r = rest.http().send(request);
      ASSERT_TRUE(r) << method << " " << concrete;
      EXPECT_NE(r->status, 405) << method << " " << concrete << ": " << r->body;
      EXPECT_THAT(r->body, ::testing::Not(::testing::HasSubstr("no route")))
          << method << " " << concrete;
    }
  }
}

}  // namespace
}  // namespace skimap::testing
