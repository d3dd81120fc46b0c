// An in-process skimapd on a real localhost port and a client connected to it.
#ifndef TESTS_SERVER_MAPS_SERVER_FIXTURE_H_
#define TESTS_SERVER_MAPS_SERVER_FIXTURE_H_

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <memory>
#include <string>

#include "absl/strings/str_cat.h"
#include "client/map_client.h"
#include "server/app/server.h"

namespace skimap::testing {

class ServerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    server::Server::Options options;
    options.grpc.address = "127.0.0.1:0";
    options.maps.worker_threads = 1;
    options.maps.max_frame_bytes = 4 << 20;
    options.grpc.max_message_bytes = 16 << 20;
    options.grpc.map_service.max_in_flight = 4;
    auto server = server::Server::Start(options);
    ASSERT_TRUE(server.ok()) << server.status();
    server_ = *std::move(server);
    client_ = client::MapClient::Connect(absl::StrCat("127.0.0.1:", server_->grpc_port()));
  }

  // Creates maps/{id} at `resolution`; fails the test otherwise.
  void CreateMap(const std::string& id, double resolution = 0.05) {
    v1::CreateMapRequest request;
    request.set_map_id(id);
    request.mutable_options()->set_resolution(resolution);
    auto map = client_->CreateMap(request);
    ASSERT_TRUE(map.ok()) << map.status();
  }

  std::unique_ptr<server::Server> server_;
  std::unique_ptr<client::MapClient> client_;
};

// The cell of `grid` (raw data) holding world point (x, y).
inline int8_t GridCell(const v1::OccupancyGrid& grid, double x, double y) {
  const int i = int(std::floor((x - grid.origin_x()) / grid.resolution()));
  const int j = int(std::floor((y - grid.origin_y()) / grid.resolution()));
  return static_cast<int8_t>(grid.data()[size_t(j) * grid.width() + i]);
}

}  // namespace skimap::testing

#endif  // TESTS_SERVER_MAPS_SERVER_FIXTURE_H_
