// REST tests: an in-process Server (server/app/server.h) with its gRPC and HTTP adapters on
// free loopback ports, and a real HTTP client (httplib::Client) talking to it over TCP.
//
//   RestServer s({.cors_origins = {"https://viewer.example"}});
//   httplib::Result r = s.http().Get("/v1/maps");
//   v1::ListMapsResponse maps = ParseJson<v1::ListMapsResponse>(r);   // rest_json.h
//
// Thread safety: a test-thread object.
#ifndef TESTS_SERVER_HTTP_REST_FIXTURE_H_
#define TESTS_SERVER_HTTP_REST_FIXTURE_H_

#include <gtest/gtest.h>

#include <memory>
#include <string>

#include "server/app/server.h"
#include "tests/server/http/http_client.h"
#include "tests/server/http/rest_json.h"

namespace skimap::testing {

struct RestServerOptions {
  size_t max_body_bytes = size_t{4} << 20;
  std::vector<std::string> cors_origins;
  std::string objects_db_path;  // "" = in memory
};

class RestServer {
 public:
  explicit RestServer(const RestServerOptions& o = {}) {
    server::Server::Options options;
    options.grpc.address = "127.0.0.1:0";
    options.http.address = "127.0.0.1:0";
    options.http.threads = 4;
    options.http.max_body_bytes = o.max_body_bytes;
    options.http.cors_origins = o.cors_origins;
    options.maps.worker_threads = 2;
    options.objects.db_path = o.objects_db_path;
    auto started = server::Server::Start(options);
    EXPECT_TRUE(started.ok()) << started.status();
    if (!started.ok()) return;
    server_ = *std::move(started);
    client_ = std::make_unique<httplib::Client>("127.0.0.1", server_->http_port());
    client_->set_read_timeout(60);
    client_->set_write_timeout(60);
  }

  server::Server& server() { return *server_; }
  httplib::Client& http() { return *client_; }

 private:
  std::unique_ptr<server::Server> server_;
  std::unique_ptr<httplib::Client> client_;
};

}  // namespace skimap::testing

#endif  // TESTS_SERVER_HTTP_REST_FIXTURE_H_
