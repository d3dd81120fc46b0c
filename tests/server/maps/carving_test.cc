// Free-space carving (MapOptions.carve_free_space) over real gRPC: a camera 0.8 m up looks
// horizontally at a wall 3 m away. Its vertical field of view (+-26 degrees) first meets
// the floor 1.6 m ahead, so the cells between the camera and 1.6 m have no floor
// observation: unknown without carving, free with it.
#include <cmath>

#include "tests/common/synthetic_scene.h"
#include "tests/server/maps/server_fixture.h"

namespace skimap::testing {
namespace {

using ::testing::HasSubstr;

SceneBox Wall() {
  SceneBox wall;
  wall.min = {3.0, -2.0, 0.0};
  wall.max = {3.1, 2.0, 2.0};
  return wall;
}

Eigen::Isometry3d FacingTheWall() { return LookingAlong({0, 0, 0.8}, {1, 0, 0}); }

class CarvingTest : public ServerTest {
 protected:
  void CreateCarvingMap(const std::string& id, bool carve) {
    v1::CreateMapRequest request;
    request.set_map_id(id);
    request.mutable_options()->set_carve_free_space(carve);
    request.mutable_options()->set_carve_pixel_stride(2);
    auto map = client_->CreateMap(request);
    ASSERT_TRUE(map.ok()) << map.status();
  }

  v1::OccupancyGrid Grid(const std::string& map) {
    v1::GetOccupancyGridRequest request;
    request.set_map(map);
    request.mutable_region()->set_min_x(-0.5);
    request.mutable_region()->set_min_y(-1.5);
    request.mutable_region()->set_max_x(3.6);
    request.mutable_region()->set_max_y(1.5);
    auto grid = client_->GetOccupancyGrid(request);
    EXPECT_TRUE(grid.ok()) << grid.status();
    return grid.ok() ? *grid : v1::OccupancyGrid();
  }
};

TEST_F(CarvingTest, CarvingFreesCellsBetweenCameraAndWallThatShowNoFloor) {
  CreateCarvingMap("plain", false);
  CreateCarvingMap("carved", true);
  for (const char* map : {"maps/plain", "maps/carved"}) {
    auto ack = client_->IntegrateFrame(MakeFrame(map, 1, FacingTheWall(), {}, Wall()));
    ASSERT_TRUE(ack.ok()) << ack.status();
  }
  const v1::OccupancyGrid plain = Grid("maps/plain"), carved = Grid("maps/carved");
  ASSERT_EQ(plain.data().size(), carved.data().size());
  int near_cells = 0;
  for (double x = 0.3; x < 1.4; x += 0.05) {
    for (double y = -0.1; y <= 0.1; y += 0.05) {
      ++near_cells;
      EXPECT_EQ(GridCell(plain, x, y), -1) << "no floor seen at " << x << ", " << y;
      EXPECT_EQ(GridCell(carved, x, y), 0) << "rays crossed " << x << ", " << y;
    }
  }
  EXPECT_GE(near_cells, 110);  // 22 x 5 cells checked (a count of the loop, not a measure)
  for (const v1::OccupancyGrid* grid : {&plain, &carved}) {
    EXPECT_EQ(GridCell(*grid, 2.2, 0.0), 0) << "seen floor is free either way";
    EXPECT_EQ(GridCell(*grid, 3.02, 0.0), 100) << "the wall is occupied either way";
    EXPECT_EQ(GridCell(*grid, 3.4, 0.0), -1) << "behind the wall is unknown either way";
    EXPECT_EQ(GridCell(*grid, 0.5, 1.2), -1) << "outside the field of view is unknown";
  }
  // Carving never frees a cell with a surface in the band.
  for (size_t i = 0; i < plain.data().size(); ++i) {
    if (int8_t(plain.data()[i]) == 100) {
      ASSERT_EQ(int8_t(carved.data()[i]), 100) << i;
    }
  }
  auto info = client_->GetMap("maps/carved");
  ASSERT_TRUE(info.ok());
  EXPECT_TRUE(info->options().carve_free_space());
  EXPECT_GE(info->stats().free_voxels(), 1650u);  // measured 2466 (2026-11-23); two thirds
  auto plain_info = client_->GetMap("maps/plain");
  ASSERT_TRUE(plain_info.ok());
  EXPECT_EQ(plain_info->stats().free_voxels(), 0u);
}

TEST_F(CarvingTest, UpdatePosesMovesFreeSpaceWithoutResidue) {
  CreateCarvingMap("moved", true);
  CreateCarvingMap("reference", true);
  Eigen::Isometry3d shifted = FacingTheWall();
  shifted.translation().y() += 0.7;
  ASSERT_TRUE(
      client_->IntegrateFrame(MakeFrame("maps/moved", 3, FacingTheWall(), {}, Wall())).ok());
  v1::UpdatePosesRequest update;
  update.set_map("maps/moved");
  update.add_updates()->set_sequence(3);
  SetPose(shifted, update.mutable_updates(0)->mutable_pose());
  ASSERT_TRUE(client_->UpdatePoses(update).ok());
  // The reference integrates the same depth image directly with the shifted pose.
  v1::Frame frame = MakeFrame("maps/reference", 3, FacingTheWall(), {}, Wall());
  SetPose(shifted, frame.mutable_pose());
  ASSERT_TRUE(client_->IntegrateFrame(frame).ok());
  const v1::OccupancyGrid moved = Grid("maps/moved"), reference = Grid("maps/reference");
  EXPECT_EQ(moved.data(), reference.data());
  EXPECT_EQ(GridCell(moved, 0.8, 0.7), 0);
  EXPECT_EQ(GridCell(moved, 0.8, -0.5), -1) << "free space left behind at the old pose";
  auto a = client_->GetMap("maps/moved"), b = client_->GetMap("maps/reference");
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(a->stats().free_voxels(), b->stats().free_voxels());
}

TEST_F(CarvingTest, BadCarvingStrideIsRejectedNamingTheField) {
  v1::CreateMapRequest request;
  request.set_map_id("bad");
  request.mutable_options()->set_carve_free_space(true);
  request.mutable_options()->set_carve_pixel_stride(0);
  auto map = client_->CreateMap(request);
  EXPECT_EQ(map.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(map.status().message(), HasSubstr("options.carve_pixel_stride"));
}

}  // namespace
}  // namespace skimap::testing
