#include "skimap/map_queries.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace skimap {
namespace {

// A 2 m x 1 m floor at z = 0 with a 0.4 m x 0.4 m table top at z = 0.7 over x in
// [0.4, 0.8), y in [0.2, 0.6), and a post from the floor to 1.0 m at x, y in [1.5, 1.6).
// The floor is missing under x >= 1.8 (never observed).
void FillRoom(SkiMap<WeightVoxel>& map) {
  for (int x = 0; x < 18; ++x) {
    for (int y = 0; y < 10; ++y) map.IntegrateKey({x, y, 0}, {1});
  }
  for (int x = 4; x < 8; ++x) {
    for (int y = 2; y < 6; ++y) map.IntegrateKey({x, y, 7}, {3});
  }
  for (int z = 0; z < 10; ++z) map.IntegrateKey({15, 5, z}, {1});
}

TEST(MapQueriesTest, OccupancyGridIsTriStateInNavMsgsLayout) {
  SkiMap<WeightVoxel> map({.resolution = 0.1});
  FillRoom(map);
  map.IntegrateKey({19, 9, 5}, {1});  // something floating in the band, no floor below
  absl::StatusOr<OccupancyGrid> grid =
      ComputeOccupancyGrid(map, {.band_min_z = 0.15, .band_max_z = 1.2, .floor_min_z = -0.2});
  ASSERT_TRUE(grid.ok()) << grid.status();
  const RasterGeometry& g = grid->geometry;
  EXPECT_EQ(g.width, 20);
  EXPECT_EQ(g.height, 10);
  EXPECT_DOUBLE_EQ(g.origin_x, 0);
  EXPECT_DOUBLE_EQ(g.origin_y, 0);
  auto cell = [&](int i, int j) { return grid->cells[j * g.width + i]; };
  EXPECT_EQ(cell(0, 0), OccupancyGrid::kFree);       // floor only
  EXPECT_EQ(cell(5, 3), OccupancyGrid::kOccupied);   // table top in the band
  EXPECT_EQ(cell(15, 5), OccupancyGrid::kOccupied);  // post
  EXPECT_EQ(cell(18, 0), OccupancyGrid::kUnknown);   // no floor seen
  EXPECT_EQ(cell(19, 9), OccupancyGrid::kOccupied);  // obstacle without floor
  int occupied = 0;
  for (int8_t c : grid->cells) occupied += c == OccupancyGrid::kOccupied;
  EXPECT_EQ(occupied, 16 + 1 + 1);
}

TEST(MapQueriesTest, BandAboveTheTableSeesItAsFree) {
  SkiMap<WeightVoxel> map({.resolution = 0.1});
  FillRoom(map);
  auto grid = ComputeOccupancyGrid(map, {.band_min_z = 0.8, .band_max_z = 2, .floor_min_z = -1});
  ASSERT_TRUE(grid.ok());
  EXPECT_EQ(grid->cells[3 * grid->geometry.width + 5], OccupancyGrid::kFree);
  EXPECT_EQ(grid->cells[5 * grid->geometry.width + 15], OccupancyGrid::kOccupied);
}

TEST(MapQueriesTest, MinWeightIgnoresWeakVoxels) {
  SkiMap<WeightVoxel> map({.resolution = 0.1});
  FillRoom(map);
  auto grid = ComputeOccupancyGrid(
      map, {.band_min_z = 0.15, .band_max_z = 1.2, .floor_min_z = -0.2, .min_weight = 2});
  ASSERT_TRUE(grid.ok());
  EXPECT_EQ(grid->cells[3 * grid->geometry.width + 5], OccupancyGrid::kOccupied);  // weight 3
  EXPECT_EQ(grid->cells[0], OccupancyGrid::kUnknown);  // floor weight 1 < 2
}

TEST(MapQueriesTest, RegionSelectsCellsAndSetsOrigin) {
  SkiMap<WeightVoxel> map({.resolution = 0.1});
  FillRoom(map);
  auto grid = ComputeOccupancyGrid(map, {.region = Region2D{0.45, 0.25, 0.95, 0.55},
                                         .band_min_z = 0.15,
                                         .band_max_z = 1.2,
                                         .floor_min_z = -0.2});
  ASSERT_TRUE(grid.ok());
  EXPECT_EQ(grid->geometry.width, 6);   // keys 4..9
  EXPECT_EQ(grid->geometry.height, 4);  // keys 2..5
  EXPECT_NEAR(grid->geometry.origin_x, 0.4, 1e-12);
  EXPECT_NEAR(grid->geometry.origin_y, 0.2, 1e-12);
  EXPECT_EQ(grid->cells[0], OccupancyGrid::kOccupied);  // key (4, 2): table
  EXPECT_EQ(grid->cells[5], OccupancyGrid::kFree);      // key (9, 2): floor
}

TEST(MapQueriesTest, BadRequestsGetClearErrors) {
  SkiMap<WeightVoxel> map({.resolution = 0.1});
  FillRoom(map);
  EXPECT_EQ(ComputeOccupancyGrid(map, {.band_min_z = 1, .band_max_z = 0}).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(ComputeOccupancyGrid(map, {.region = Region2D{1, 0, 0, 1}}).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(ComputeHeightMap(map, {.region = Region2D{-5e3, -5e3, 5e3, 5e3}}).status().code(),
            absl::StatusCode::kResourceExhausted);
  SkiMap<WeightVoxel> empty({.resolution = 0.1});
  auto g = ComputeOccupancyGrid(empty, {});
  ASSERT_TRUE(g.ok());
  EXPECT_EQ(g->geometry.width, 0);
  EXPECT_TRUE(g->cells.empty());
}

TEST(MapQueriesTest, MaxCellsRefusesLargerRastersFromTheGeometryAlone) {
  SkiMap<WeightVoxel> map({.resolution = 0.1});
  FillRoom(map);  // its footprint is 18 x 10 cells
  EXPECT_EQ(ComputeHeightMap(map, {.max_cells = 179}).status().code(),
            absl::StatusCode::kResourceExhausted);
  EXPECT_TRUE(ComputeHeightMap(map, {.max_cells = 180}).ok());
  absl::StatusOr<OccupancyGrid> refused = ComputeOccupancyGrid(map, {.max_cells = 179});
  EXPECT_EQ(refused.status().code(), absl::StatusCode::kResourceExhausted);
  EXPECT_NE(refused.status().message().find("18 x 10 cells exceeds the limit of 179 cells"),
            std::string::npos)
      << refused.status();
  EXPECT_TRUE(ComputeOccupancyGrid(map, {.max_cells = 180}).ok());
}

TEST(MapQueriesTest, PoolGivesTheSameRasters) {
  ThreadPool pool(2);
  SkiMap<WeightVoxel> map({.resolution = 0.02});
  std::mt19937 rng(4);
  std::uniform_int_distribution<int> c(-300, 300), z(-20, 100);
  for (int i = 0; i < 100000; ++i) map.IntegrateKey({c(rng), c(rng), z(rng)}, {1});
  auto grid = ComputeOccupancyGrid(map, {});
  auto grid_pool = ComputeOccupancyGrid(map, {.pool = &pool});
  ASSERT_TRUE(grid.ok() && grid_pool.ok());
  EXPECT_EQ(grid->cells, grid_pool->cells);
  auto hm = ComputeHeightMap(map, {.min_weight = 2});
  auto hm_pool = ComputeHeightMap(map, {.min_weight = 2, .pool = &pool});
  ASSERT_TRUE(hm.ok() && hm_pool.ok());
  ASSERT_EQ(hm->heights.size(), hm_pool->heights.size());
  for (size_t i = 0; i < hm->heights.size(); ++i) {
    ASSERT_TRUE(hm->heights[i] == hm_pool->heights[i] ||
                (std::isnan(hm->heights[i]) && std::isnan(hm_pool->heights[i])));
  }
}

TEST(MapQueriesTest, HeightMapGivesTopSurfaceAndNaNForUnknown) {
  SkiMap<WeightVoxel> map({.resolution = 0.1});
  FillRoom(map);
  auto hm = ComputeHeightMap(map, {});
  ASSERT_TRUE(hm.ok()) << hm.status();
  const RasterGeometry& g = hm->geometry;
  ASSERT_EQ(g.width, 18);
  auto h = [&](int i, int j) { return hm->heights[j * g.width + i]; };
  EXPECT_NEAR(h(0, 0), 0.05, 1e-6);   // floor voxel centre
  EXPECT_NEAR(h(5, 3), 0.75, 1e-6);   // table top
  EXPECT_NEAR(h(15, 5), 0.95, 1e-6);  // top of the post
  auto weighted = ComputeHeightMap(map, {.region = Region2D{0, 0, 2.5, 1}, .min_weight = 2});
  ASSERT_TRUE(weighted.ok());
  EXPECT_TRUE(std::isnan(weighted->heights[0]));
  EXPECT_EQ(weighted->geometry.width, 26);
  EXPECT_NEAR(weighted->heights[3 * 26 + 5], 0.75, 1e-6);
  EXPECT_TRUE(std::isnan(weighted->heights[9 * 26 + 25]));  // never observed
}

}  // namespace
}  // namespace skimap
