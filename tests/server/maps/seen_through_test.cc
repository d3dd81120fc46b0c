// Seen-through obstacles in the occupancy grid, over real gRPC (server/core/maps/
// grid_views.h): a box on the floor (0.3-0.7 m in x, +-0.2 m in y, 0.5 m high) is seen, then
// taken away, and the next frame sees the floor where it stood.
#include <cmath>

#include "tests/common/synthetic_scene.h"
#include "tests/server/maps/server_fixture.h"

namespace skimap::testing {
namespace {

// No box in view: it stands 50 m away.
SceneBox Gone() {
  SceneBox far;
  far.min = {50, 50, 0};
  far.max = {50.4, 50.4, 0.5};
  return far;
}

class SeenThroughTest : public ServerTest {
 protected:
  void Integrate(const std::string& map, uint64_t sequence, const Eigen::Isometry3d& pose,
                 const SceneBox& box) {
    auto ack = client_->IntegrateFrame(MakeFrame(map, sequence, pose, {}, box));
    ASSERT_TRUE(ack.ok()) << ack.status();
  }
  v1::OccupancyGrid Grid(const std::string& map, bool keep_seen_through = false) {
    v1::GetOccupancyGridRequest request;
    request.set_map(map);
    request.mutable_region()->set_min_x(-1.0);
    request.mutable_region()->set_min_y(-1.0);
    request.mutable_region()->set_max_x(2.0);
    request.mutable_region()->set_max_y(1.0);
    request.set_keep_seen_through(keep_seen_through);
    auto grid = client_->GetOccupancyGrid(request);
    EXPECT_TRUE(grid.ok()) << grid.status();
    return grid.ok() ? *grid : v1::OccupancyGrid();
  }
};

int CountCells(const v1::OccupancyGrid& grid, int8_t value) {
  int n = 0;
  for (char c : grid.data()) n += int8_t(c) == value;
  return n;
}

// The box's footprint, 5 cm cells whose centres lie inside it.
template <class Fn>
void ForEachBoxCell(Fn&& fn) {
  for (double x = 0.325; x < 0.7; x += 0.05) {
    for (double y = -0.175; y < 0.2; y += 0.05) fn(x, y);
  }
}

TEST_F(SeenThroughTest, AnObstacleTakenAwayIsClearedWhenALaterViewSeesTheFloorWhereItStood) {
  CreateMap("room");
  Integrate("maps/room", 1, DefaultView(), SceneBox{});
  const v1::OccupancyGrid before = Grid("maps/room");
  EXPECT_EQ(GridCell(before, 0.5, 0.0), 100);
  EXPECT_GE(CountCells(before, 100), 40);  // the box's front and top
  // Taken away; seen again from 0.8 m to the side, looking at where it stood.
  const Eigen::Vector3d aside(-1.3, 0.8, 1.5);
  Integrate("maps/room", 2, LookingAlong(aside, Eigen::Vector3d(0.5, 0, 0.25) - aside), Gone());
  const v1::OccupancyGrid after = Grid("maps/room"), kept = Grid("maps/room", true);
  int cleared = 0, cells = 0;
  ForEachBoxCell([&](double x, double y) {
    ++cells;
    if (GridCell(before, x, y) == 100) EXPECT_EQ(GridCell(kept, x, y), 100) << x << ", " << y;
    if (GridCell(before, x, y) == 100 && GridCell(after, x, y) == 0) ++cleared;
  });
  ASSERT_EQ(cells, 64);
  // Every cell of the box that was occupied is free now: the floor where it stood was seen.
  int still = 0;
  ForEachBoxCell([&](double x, double y) { still += GridCell(after, x, y) == 100; });
  EXPECT_EQ(still, 0);
  EXPECT_EQ(CountCells(after, 100), 0) << "no obstacle is left anywhere";
  EXPECT_GE(cleared, 20);
}

TEST_F(SeenThroughTest, AnObstacleThatStaysIsNeverClearedByTheViewsThatSeeIt) {
  // Faces off the 5 cm cell edges: a face exactly on an edge puts its voxels in the cell
  // beyond, whose cube a view may rightly see through.
  SceneBox box;
  box.min = {0.32, -0.18, 0.0};
  box.max = {0.68, 0.18, 0.48};
  CreateMap("static");
  for (uint64_t i = 0; i < 12; ++i) Integrate("maps/static", i + 1, OrbitView(i), box);
  const v1::OccupancyGrid cleared = Grid("maps/static"), kept = Grid("maps/static", true);
  EXPECT_GE(CountCells(kept, 100), 60);
  ASSERT_EQ(cleared.data().size(), kept.data().size());
  for (size_t i = 0; i < kept.data().size(); ++i) {
    EXPECT_EQ(int(cleared.data()[i]), int(kept.data()[i]))
        << "a view cleared a cell of a box that is there: " << i % kept.width() << ", "
        << i / kept.width();
  }
  ForEachBoxCell(
      [&](double x, double y) { EXPECT_EQ(GridCell(cleared, x, y), 100) << x << ", " << y; });
}

TEST_F(SeenThroughTest, TheObstacleComesBackWhenANewerViewSeesItAgain) {
  CreateMap("back");
  const Eigen::Vector3d aside(-1.3, 0.8, 1.5);
  const Eigen::Isometry3d side = LookingAlong(aside, Eigen::Vector3d(0.5, 0, 0.25) - aside);
  Integrate("maps/back", 1, DefaultView(), SceneBox{});
  Integrate("maps/back", 2, side, Gone());
  EXPECT_EQ(GridCell(Grid("maps/back"), 0.5, 0.0), 0);
  Integrate("maps/back", 3, DefaultView(), SceneBox{});  // put back, seen from the start
  EXPECT_EQ(GridCell(Grid("maps/back"), 0.5, 0.0), 100);
}

TEST_F(SeenThroughTest, UpdatePosesMovesTheViewsWithTheirFrames) {
  // Frame 2 first arrives with a pose looking away from the box; corrected, it is the
  // side view that sees the floor where the box stood. The grid must be the one of a map
  // that got the right pose at once.
  CreateMap("moved");
  CreateMap("reference");
  const Eigen::Vector3d aside(-1.3, 0.8, 1.5);
  const Eigen::Isometry3d side = LookingAlong(aside, Eigen::Vector3d(0.5, 0, 0.25) - aside);
  const Eigen::Isometry3d away = LookingAlong({-1.3, 0.8, 1.5}, {-1, 0.3, -0.6});
  Integrate("maps/moved", 1, DefaultView(), SceneBox{});
  // The depth image is the side view's; only the pose sent is wrong.
  v1::Frame wrong = MakeFrame("maps/moved", 2, side, {}, Gone());
  SetPose(away, wrong.mutable_pose());
  ASSERT_TRUE(client_->IntegrateFrame(wrong).ok());
  EXPECT_EQ(GridCell(Grid("maps/moved"), 0.5, 0.0), 100) << "the wrong pose looks elsewhere";
  v1::UpdatePosesRequest update;
  update.set_map("maps/moved");
  update.add_updates()->set_sequence(2);
  SetPose(side, update.mutable_updates(0)->mutable_pose());
  ASSERT_TRUE(client_->UpdatePoses(update).ok());
  Integrate("maps/reference", 1, DefaultView(), SceneBox{});
  Integrate("maps/reference", 2, side, Gone());
  const v1::OccupancyGrid moved = Grid("maps/moved"), reference = Grid("maps/reference");
  EXPECT_EQ(GridCell(moved, 0.5, 0.0), 0);
  EXPECT_TRUE(moved.data() == reference.data());
}

}  // namespace
}  // namespace skimap::testing
