// Frames and small clients for the operations tests (metrics, logs, load): synthetic
// 32 x 24 raw-depth frames of a wall 1 m ahead, a gRPC stub with chosen metadata, and a
// parser of the Prometheus text exposition.
//
// Thread safety: pure functions and test-thread values.
#ifndef TESTS_SERVER_APP_TEST_FRAMES_H_
#define TESTS_SERVER_APP_TEST_FRAMES_H_

#include <grpcpp/grpcpp.h>

#include <cstdint>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "skimap/v1/map_service.grpc.pb.h"

namespace skimap::testing {

// A 32 x 24 frame of a wall 1 m ahead of a camera at x = 0.05 * sequence (new space for
// each frame); `width` x 24 pixels claimed in the intrinsics (above 32: a frame whose depth
// does not match its size, refused as INVALID_ARGUMENT).
inline v1::Frame WallFrame(const std::string& map, uint64_t sequence, int width = 32) {
  v1::Frame f;
  f.set_map(map);
  f.set_sequence(sequence);
  f.mutable_pose()->mutable_rotation()->set_w(1);
  f.mutable_pose()->mutable_translation()->set_x(0.05 * double(sequence));
  v1::CameraIntrinsics& k = *f.mutable_intrinsics();
  k.set_width(width);
  k.set_height(24);
  k.set_fx(30);
  k.set_fy(30);
  k.set_cx(16);
  k.set_cy(12);
  f.set_depth_encoding(v1::DEPTH_ENCODING_RAW_U16);
  std::string depth(32 * 24 * 2, '\0');
  for (int i = 0; i < 32 * 24; ++i) {
    depth[2 * i] = static_cast<char>(1000 & 0xff);
    depth[2 * i + 1] = static_cast<char>(1000 >> 8);
  }
  f.set_depth(std::move(depth));
  f.set_depth_scale(0.001);
  return f;
}

inline std::unique_ptr<v1::MapService::Stub> MapStub(const std::string& address) {
  return v1::MapService::NewStub(grpc::CreateChannel(address, grpc::InsecureChannelCredentials()));
}

// Every sample of a text exposition: name, labels, value.
struct Sample {
  std::string name;
  std::map<std::string, std::string> labels;
  double value = 0;
};

inline std::vector<Sample> ParseExposition(const std::string& text) {
  std::vector<Sample> samples;
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    Sample s;
    const size_t space = line.rfind(' ');
    s.value = std::stod(line.substr(space + 1));
    std::string key = line.substr(0, space);
    const size_t brace = key.find('{');
    s.name = key.substr(0, brace);
    if (brace != std::string::npos) {
      // name{a="x",b="y"}: values hold no quotes or commas in these tests.
      std::string labels = key.substr(brace + 1, key.size() - brace - 2);
      std::istringstream pairs(labels);
      std::string pair;
      while (std::getline(pairs, pair, ',')) {
        const size_t eq = pair.find('=');
        s.labels[pair.substr(0, eq)] = pair.substr(eq + 2, pair.size() - eq - 3);
      }
    }
    samples.push_back(std::move(s));
  }
  return samples;
}

// The value of the sample named `name` whose labels include `labels`; -1 if none.
inline double SampleValue(const std::vector<Sample>& samples, const std::string& name,
                          const std::map<std::string, std::string>& labels = {}) {
  for (const Sample& s : samples) {
    if (s.name != name) continue;
    bool match = true;
    for (const auto& [k, v] : labels) {
      auto it = s.labels.find(k);
      match = match && it != s.labels.end() && it->second == v;
    }
    if (match) return s.value;
  }
  return -1;
}

}  // namespace skimap::testing

#endif  // TESTS_SERVER_APP_TEST_FRAMES_H_
