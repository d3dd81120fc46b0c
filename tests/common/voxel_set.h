// The voxels of a map as a set of (centre x, y, z, weight, rgb), read through the gRPC
// client, for tests that compare a map before and after a crash, restart, reload or
// move to another fleet node.
#ifndef TESTS_COMMON_VOXEL_SET_H_
#define TESTS_COMMON_VOXEL_SET_H_

#include <gtest/gtest.h>

#include <cstdint>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include "client/map_client.h"

namespace skimap::testing {

using VoxelSet = std::set<std::tuple<double, double, double, float, uint32_t>>;

// Every voxel of `map` (no weight filter); a failed read fails the test and reads empty.
inline VoxelSet Voxels(client::MapClient& client, const std::string& map) {
  v1::GetVoxelsRequest request;
  request.set_map(map);
  request.set_min_voxel_weight(0);
  auto voxels = client.GetAllVoxels(request);
  EXPECT_TRUE(voxels.ok()) << map << ": " << voxels.status();
  VoxelSet out;
  for (const v1::Voxel& v : voxels.value_or(std::vector<v1::Voxel>{})) {
    out.insert({v.center().x(), v.center().y(), v.center().z(), v.weight(), v.rgb()});
  }
  return out;
}

// "same" when equal, else the sizes and how many voxels differ (for readable failures:
// EXPECT_EQ(Compare(a, b), "same")).
inline std::string Compare(const VoxelSet& a, const VoxelSet& b) {
  if (a == b) return "same";
  size_t only_a = 0, only_b = 0;
  std::string first;  // the first voxel only in `a` (x y z weight rgb)
  for (const auto& v : a) {
    if (b.count(v)) continue;
    if (only_a++ == 0) {
      first = std::to_string(std::get<0>(v)) + " " + std::to_string(std::get<1>(v)) + " " +
              std::to_string(std::get<2>(v)) + " weight " + std::to_string(std::get<3>(v)) +
              " rgb " + std::to_string(std::get<4>(v));
    }
  }
  for (const auto& v : b) only_b += !a.count(v);
  return "sizes " + std::to_string(a.size()) + " and " + std::to_string(b.size()) + ", " +
         std::to_string(only_a) + " voxels only in the first (the first: " + first + "), " +
         std::to_string(only_b) + " only in the second";
}

}  // namespace skimap::testing

#endif  // TESTS_COMMON_VOXEL_SET_H_
