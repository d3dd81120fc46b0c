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

}  // namespace skimap::testing

#endif  // TESTS_COMMON_VOXEL_SET_H_
