// The voxels the ROS tests compare against: the test frames (ros_test_data.h) sent as
// API frames, with no ROS code in between.
//
// Thread safety: a test-thread function.
#ifndef TESTS_ROS_REFERENCE_VOXELS_H_
#define TESTS_ROS_REFERENCE_VOXELS_H_

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "client/map_client.h"
#include "tests/common/voxel_set.h"
#include "tests/ros/ros_test_data.h"

namespace skimap::testing {

// The voxels of `frames` sent as API frames (ReferenceFrame) into a new 2 cm map `id`.
// Without `with_color`, the frames carry no colour (voxels grey).
inline VoxelSet ReferenceVoxels(client::MapClient& client, const std::vector<MmFrame>& frames,
                                const std::string& id, bool with_color = true) {
  v1::CreateMapRequest create;
  create.set_map_id(id);
  create.mutable_options()->set_resolution(0.02);
  EXPECT_TRUE(client.CreateMap(create).ok());
  for (const MmFrame& f : frames) {
    v1::Frame frame = ReferenceFrame(f, "maps/" + id, f.index);
    if (!with_color) {
      frame.clear_color();
      frame.set_color_encoding(v1::COLOR_ENCODING_NONE);
    }
    auto ack = client.IntegrateFrame(frame);
    EXPECT_TRUE(ack.ok()) << ack.status();
  }
  return Voxels(client, "maps/" + id);
}

}  // namespace skimap::testing

#endif  // TESTS_ROS_REFERENCE_VOXELS_H_
