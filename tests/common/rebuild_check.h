// ExpectEqualToRebuild: the fleet tests' check that a map holds exactly the frames it
// acknowledged. Frames are depth-only synthetic orbit views (synthetic_scene.h), so voxel
// weights are integer counts and the map must equal, voxel by voxel, the same frames
// streamed in order into a fresh map.
//
//   ExpectEqualToRebuild(*client, "maps/m0", {0, 1, 2}, "m0-rebuilt");
//
// Thread safety: a test-thread function.
#ifndef TESTS_COMMON_REBUILD_CHECK_H_
#define TESTS_COMMON_REBUILD_CHECK_H_

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "client/map_client.h"
#include "tests/common/synthetic_scene.h"
#include "tests/common/voxel_set.h"

namespace skimap::testing {

// CreateMap of `id` at the fleet tests' 4 cm.
inline v1::CreateMapRequest FleetMapRequest(const std::string& id) {
  v1::CreateMapRequest request;
  request.set_map_id(id);
  request.mutable_options()->set_resolution(0.04);
  return request;
}

// Rebuilds frames `sequences` (in order) into a fresh map `rebuilt_id` through `client` and
// expects `map` equal to it, with one frame per sequence.
inline void ExpectEqualToRebuild(client::MapClient& client, const std::string& map,
                                 const std::vector<uint64_t>& sequences,
                                 const std::string& rebuilt_id) {
  ASSERT_TRUE(client.CreateMap(FleetMapRequest(rebuilt_id)).ok());
  const std::string rebuilt = "maps/" + rebuilt_id;
  auto stream = client.OpenFrameStream({.window = 4}, rebuilt);
  for (uint64_t s : sequences) ASSERT_TRUE(stream->Send(MakeFrame(rebuilt, s, OrbitView(s))).ok());
  auto acks = stream->Finish();
  ASSERT_TRUE(acks.ok()) << acks.status();
  for (const v1::FrameAck& a : *acks) ASSERT_EQ(a.code(), 0) << a.message();
  auto info = client.GetMap(map);
  ASSERT_TRUE(info.ok()) << info.status();
  EXPECT_EQ(info->stats().frames(), sequences.size());
  const VoxelSet got = Voxels(client, map);
  EXPECT_GT(got.size(), 0u);
  EXPECT_EQ(got.size(), info->stats().voxels());
  EXPECT_TRUE(got == Voxels(client, rebuilt))
      << map << " differs from its " << sequences.size() << " frames rebuilt";
}

}  // namespace skimap::testing

#endif  // TESTS_COMMON_REBUILD_CHECK_H_
