// The clients of skimap-load (load_main.cc): robot streams that send frames of new space
// over gRPC StreamFrames, and query clients that ask for occupancy grids, voxel pages and
// radius searches around where the robots are, over gRPC or REST. Each records its
// latencies and errors; the main thread reads them after Stop().
//
//   RobotStream robot(stub, {.map = "maps/load0", .index = 0, .fps = 15});
//   robot.Start();  ...  robot.Stop();
//   robot.frames_acked(); robot.errors();
//
// Thread safety: Start and Stop from one thread; position() and the counters may be read
// from any thread; latencies after Stop only.
#ifndef TOOLS_LOAD_LOAD_CLIENTS_H_
#define TOOLS_LOAD_LOAD_CLIENTS_H_

#include <grpcpp/grpcpp.h>

#include <atomic>
#include <condition_variable>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "skimap/v1/map_service.grpc.pb.h"

namespace skimap::load {

// Where robot `index` is after `frames` frames: a lawnmower over a 50 m x 50 m square of
// its own, 1.5 m above the floor, looking down; each frame 0.5 m further.
struct Position {
  double x = 0, y = 0;
};
Position RobotPosition(int index, uint64_t frames);

// A frame of robot `index`'s camera (160 x 120 raw depth of a floor with a ramp).
v1::Frame RobotFrame(const std::string& map, int index, uint64_t sequence);

class RobotStream {
 public:
  struct Options {
    std::string map;  // "maps/load0"
    int index = 0;
    double fps = 15;  // frames sent per second at most
    int window = 4;   // unacknowledged frames at most
  };
  RobotStream(v1::MapService::Stub* stub, const Options& options);
  ~RobotStream();  // Stop()
  void Start();
  void Stop();  // WritesDone, waits for the last acks
  uint64_t frames_acked() const { return acked_.load(); }
  uint64_t errors() const { return errors_.load(); }
  Position position() const { return RobotPosition(options_.index, acked_.load()); }
  const std::string& first_error() const { return first_error_; }  // after Stop

 private:
  void Run();
  v1::MapService::Stub* const stub_;
  const Options options_;
  std::atomic<bool> stop_{false};
  std::atomic<uint64_t> acked_{0}, errors_{0};
  std::mutex mu_;  // in_flight_, first_error_
  std::condition_variable cv_;
  int in_flight_ = 0;
  std::string first_error_;
  std::thread thread_;
};

// Latency samples (milliseconds) and errors per query kind ("grpc grid", "rest radius").
struct QueryLog {
  std::map<std::string, std::vector<double>> latency_ms;
  std::map<std::string, uint64_t> errors;
  std::string first_error;
};

class QueryClient {
 public:
  struct Options {
    bool rest = false;  // REST (http_port) instead of gRPC
    int http_port = 0;
    int think_ms = 20;  // pause between queries
    uint32_t seed = 1;
  };
  // `robots` (not owned) name the maps and where to look.
  QueryClient(v1::MapService::Stub* stub, const std::vector<RobotStream*>& robots,
              const std::vector<std::string>& maps, const Options& options);
  ~QueryClient();
  void Start();
  void Stop();
  const QueryLog& log() const { return log_; }  // after Stop

 private:
  void Run();
  v1::MapService::Stub* const stub_;
  const std::vector<RobotStream*> robots_;
  const std::vector<std::string> maps_;
  const Options options_;
  std::atomic<bool> stop_{false};
  QueryLog log_;
  std::thread thread_;
};

}  // namespace skimap::load

#endif  // TOOLS_LOAD_LOAD_CLIENTS_H_
