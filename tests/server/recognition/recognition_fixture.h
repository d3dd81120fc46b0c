// The recognition tests' world: the sim `mini` preset (3 objects, their training orbits and
// one test scene) rendered at test time, an in-process skimapd on a localhost port with a
// data dir, the 3 objects trained through ObjectService (ORB, 300 classes) and the test
// scene streamed into a map with recognition on (policy EVERY_FRAME), while a watcher
// collects the instance events. Everything is made once per test process.
#ifndef TESTS_SERVER_RECOGNITION_RECOGNITION_FIXTURE_H_
#define TESTS_SERVER_RECOGNITION_RECOGNITION_FIXTURE_H_

#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <vector>

#include "Eigen/Geometry"
#include "client/map_client.h"
#include "server/app/server.h"
#include "skimap/v1/map_service.grpc.pb.h"

namespace skimap::testing {

// An object of the test scene: its dataset id and pose in the world.
struct TruthObject {
  int obj_id = 0;
  Eigen::Isometry3d pose;  // world <- model
};

struct RecognitionWorld {
  std::string dataset;   // mini dataset root
  std::string scene;     // its test scene folder
  std::string data_dir;  // the server's
  std::unique_ptr<server::Server> server;
  std::unique_ptr<client::MapClient> client;
  std::vector<TruthObject> truth;
  std::vector<v1::InstanceEvent> events;  // WatchInstances from 0 while streaming
  int frames = 0;                         // streamed
};

// The shared world (built on first use; fails the calling test on error).
RecognitionWorld& World();

// Restarts the world's server on its data dir (a clean stop: the final snapshot).
void RestartWorld();

// Every instance of maps/{map} (all pages).
std::vector<v1::Instance> AllInstances(client::MapClient& c, const std::string& map);

// Translation (metres) and rotation (degrees) between an instance's pose and a truth.
double TranslationError(const v1::Instance& i, const Eigen::Isometry3d& truth);
double RotationErrorDeg(const v1::Instance& i, const Eigen::Isometry3d& truth);

}  // namespace skimap::testing

#endif  // TESTS_SERVER_RECOGNITION_RECOGNITION_FIXTURE_H_
