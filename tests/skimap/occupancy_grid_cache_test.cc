// OccupancyGridCache (skimap/occupancy_grid_cache.h): after any sequence of writes
// (additions, removals that empty whole columns, Compact, Clear) and with any region,
// band and pool, its grid equals ComputeOccupancyGrid's on the same map; a query after a
// small write recomputes only the x columns that write touched.
#include "skimap/occupancy_grid_cache.h"

#include <gtest/gtest.h>

#include <random>

namespace skimap {
namespace {

void ExpectSameGrid(const absl::StatusOr<OccupancyGrid>& got,
                    const absl::StatusOr<OccupancyGrid>& want, int step) {
  ASSERT_EQ(got.ok(), want.ok()) << "step " << step << ": " << got.status() << " vs "
                                 << want.status();
  if (!want.ok()) return;
  EXPECT_EQ(got->geometry.width, want->geometry.width) << "step " << step;
  EXPECT_EQ(got->geometry.height, want->geometry.height) << "step " << step;
  EXPECT_EQ(got->geometry.key_x0, want->geometry.key_x0) << "step " << step;
  EXPECT_EQ(got->geometry.key_y0, want->geometry.key_y0) << "step " << step;
  ASSERT_EQ(got->cells, want->cells) << "step " << step;
}

TEST(OccupancyGridCacheTest, EqualsTheFullComputationAfterEveryKindOfWrite) {
  ThreadPool pool(2);
  SkiMap<WeightVoxel> map({.resolution = 0.1, .pool = &pool});
  OccupancyGridCache cache;
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> key(-40, 40), z(-5, 20), count(1, 400);
  std::uniform_real_distribution<double> coord(-5, 5);
  for (int step = 0; step < 300; ++step) {
    const int op = step % 10;
    VoxelBatch<WeightVoxel> batch;
    const int n = count(rng);
    for (int i = 0; i < n; ++i) batch.AddKey({key(rng), key(rng), z(rng)}, {float(1 + i % 3)});
    batch.Finalize();
    if (op < 6) {
      map.Integrate(batch);
    } else if (op < 8) {
      // Remove what a batch of existing voxels holds: whole voxels, often whole columns.
      VoxelBatch<WeightVoxel> removal;
      map.ForEach([&](const VoxelKey& k, const WeightVoxel& v) {
        if ((k.x + k.y + step) % 3 == 0) removal.AddKey(k, v);
      });
      removal.Finalize();
      if (!removal.empty()) map.Deintegrate(removal);
    } else if (op == 8) {
      map.Compact();
    } else if (step % 50 == 9) {
      map.Clear();
    }
    OccupancyGridOptions options;
    options.pool = step % 2 ? &pool : nullptr;
    if (step % 3 == 0) {
      const double a = coord(rng), b = coord(rng), c = coord(rng), d = coord(rng);
      options.region = Region2D{std::min(a, b), std::min(c, d), std::max(a, b), std::max(c, d)};
    }
    if (step % 37 == 0) options.band_min_z = 0.5;  // other bands: the cache starts over
    if (step % 41 == 0) options.min_weight = 2;
    ExpectSameGrid(cache.Compute(map, options), ComputeOccupancyGrid(map, options), step);
  }
}

TEST(OccupancyGridCacheTest, AQueryAfterASmallWriteRecomputesOnlyItsColumns) {
  SkiMap<WeightVoxel> map({.resolution = 0.05});
  for (int x = 0; x < 200; ++x) {
    for (int y = 0; y < 200; ++y) map.IntegrateKey({x, y, 0}, {1});
  }
  OccupancyGridCache cache;
  const OccupancyGridOptions options{.region = Region2D{0, 0, 9.99, 9.99}};
  ASSERT_TRUE(cache.Compute(map, options).ok());
  EXPECT_EQ(cache.last_recomputed(), 200u);
  ASSERT_TRUE(cache.Compute(map, options).ok());
  EXPECT_EQ(cache.last_recomputed(), 0u);
  // An obstacle over x keys 50..52.
  for (int x = 50; x < 53; ++x) map.IntegrateKey({x, 70, 10}, {1});
  absl::StatusOr<OccupancyGrid> grid = cache.Compute(map, options);
  ASSERT_TRUE(grid.ok());
  EXPECT_EQ(cache.last_recomputed(), 3u);
  EXPECT_EQ(grid->cells[70 * 200 + 51], OccupancyGrid::kOccupied);
  EXPECT_EQ(grid->cells[70 * 200 + 53], OccupancyGrid::kFree);
  ExpectSameGrid(grid, ComputeOccupancyGrid(map, options), 0);
}

TEST(OccupancyGridCacheTest, AColumnEmptiedAndMadeAgainBetweenQueriesIsRecomputedWhole) {
  SkiMap<WeightVoxel> map({.resolution = 0.1});
  map.IntegrateKey({5, 3, 5}, {1});    // y block 0, occupied
  map.IntegrateKey({5, 130, 5}, {1});  // y block 2
  OccupancyGridCache cache;
  const OccupancyGridOptions options{.region = Region2D{0, 0, 1, 15}};
  ExpectSameGrid(cache.Compute(map, options), ComputeOccupancyGrid(map, options), 0);
  // Column x = 5 goes (every voxel removed), then comes back with block 2 only.
  map.DeintegrateKey({5, 3, 5}, {1});
  map.DeintegrateKey({5, 130, 5}, {1});
  map.IntegrateKey({5, 140, 5}, {1});
  absl::StatusOr<OccupancyGrid> grid = cache.Compute(map, options);
  ExpectSameGrid(grid, ComputeOccupancyGrid(map, options), 1);
  EXPECT_EQ(grid->cells[3 * grid->geometry.width + 5], OccupancyGrid::kUnknown);
}

TEST(OccupancyGridCacheTest, TwoMapsNeverShareAColumnVersion) {
  // One cache asked about two maps in turn must not take one map's columns for the other's.
  SkiMap<WeightVoxel> a({.resolution = 0.1}), b({.resolution = 0.1});
  a.IntegrateKey({1, 1, 0}, {1});
  b.IntegrateKey({1, 1, 5}, {1});
  OccupancyGridCache cache;
  const OccupancyGridOptions options{.region = Region2D{0, 0, 0.5, 0.5}};
  ExpectSameGrid(cache.Compute(a, options), ComputeOccupancyGrid(a, options), 0);
  ExpectSameGrid(cache.Compute(b, options), ComputeOccupancyGrid(b, options), 1);
}

}  // namespace
}  // namespace skimap
