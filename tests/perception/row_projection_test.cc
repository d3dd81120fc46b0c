// ProjectRow (perception/row_projection.h): the vector path (AVX2 on this machine) writes
// exactly what the scalar reference writes, and the reference's keys are Grid::ToKey's,
// on random rows, rows of every length (the vector loop's tail), voxel boundaries on both
// sides of zero, and coordinates outside the key range.
#include "perception/row_projection.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "skimap/grid.h"

namespace skimap::perception {
namespace {

struct Row {
  std::vector<uint16_t> depth;
  std::vector<double> rx, ry, rz;
  RowProjection p{};
  void Bind() {
    p.depth = depth.data(), p.cols = static_cast<int>(depth.size());
    p.ray_x = rx.data(), p.ray_y = ry.data(), p.ray_z = rz.data();
  }
};

struct Out {
  std::vector<int32_t> x, y, z;
  std::vector<uint8_t> state;
  RowCounts counts;
};

Out Project(const Row& row, bool scalar) {
  const size_t n = row.depth.size();
  // Poisoned, so a pixel the projection forgets to write shows.
  Out o{std::vector<int32_t>(n, 77),
        std::vector<int32_t>(n, 77),
        std::vector<int32_t>(n, 77),
        std::vector<uint8_t>(n, 77),
        {}};
  o.counts = scalar ? ProjectRowScalar(row.p, o.x.data(), o.y.data(), o.z.data(), o.state.data())
                    : ProjectRow(row.p, o.x.data(), o.y.data(), o.z.data(), o.state.data());
  return o;
}

// Both paths agree, and the reference matches Grid::ToKey pixel by pixel.
void ExpectExact(const Row& row, const Grid& grid) {
  const Out fast = Project(row, false), ref = Project(row, true);
  ASSERT_EQ(fast.x, ref.x);
  ASSERT_EQ(fast.y, ref.y);
  ASSERT_EQ(fast.z, ref.z);
  ASSERT_EQ(fast.state, ref.state);
  ASSERT_EQ(fast.counts.in_range, ref.counts.in_range);
  ASSERT_EQ(fast.counts.out_of_range, ref.counts.out_of_range);
  const RowProjection& p = row.p;
  uint32_t in_range = 0, out_of_range = 0;
  for (int c = 0; c < p.cols; ++c) {
    const double z = row.depth[c] * p.scale;
    const bool valid = row.depth[c] != 0, inside = z >= p.min_depth && z <= p.max_depth;
    in_range += valid && inside;
    out_of_range += valid && !inside;
    const Point3 point{z * (p.base_x + p.ray_x[c]) + p.tx, z * (p.base_y + p.ray_y[c]) + p.ty,
                       z * (p.base_z + p.ray_z[c]) + p.tz};
    VoxelKey key;
    const bool keyed = grid.ToKey(point, &key);
    const uint8_t want = !(valid && inside) ? kRowSkip : keyed ? kRowUse : kRowNoKey;
    ASSERT_EQ(ref.state[c], want) << "column " << c;
    if (want == kRowUse) {
      ASSERT_EQ(ref.x[c], key.x) << "column " << c;
      ASSERT_EQ(ref.y[c], key.y) << "column " << c;
      ASSERT_EQ(ref.z[c], key.z) << "column " << c;
    } else {
      ASSERT_EQ(ref.x[c], 0);
      ASSERT_EQ(ref.y[c], 0);
      ASSERT_EQ(ref.z[c], 0);
    }
  }
  EXPECT_EQ(ref.counts.in_range, in_range);
  EXPECT_EQ(ref.counts.out_of_range, out_of_range);
}

Row RandomRow(std::mt19937& rng, int cols, const Grid& grid) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::uniform_int_distribution<int> d(0, 9000);
  Row row;
  for (int c = 0; c < cols; ++c) {
    const int v = d(rng);
    row.depth.push_back(v < 900 ? 0 : static_cast<uint16_t>(v));  // ~10 % without depth
    row.rx.push_back(unit(rng) * 0.6);
    row.ry.push_back(unit(rng) * 0.6);
    row.rz.push_back(unit(rng) * 0.6);
  }
  row.p.scale = 0.001;
  row.p.min_depth = 0.3, row.p.max_depth = 7.0;  // some valid depth falls outside
  row.p.base_x = unit(rng), row.p.base_y = unit(rng), row.p.base_z = 1.0 + unit(rng) * 0.2;
  row.p.tx = unit(rng) * 50, row.p.ty = unit(rng) * 50, row.p.tz = unit(rng) * 3;
  row.p.ox = grid.origin().x, row.p.oy = grid.origin().y, row.p.oz = grid.origin().z;
  row.p.inv_resolution = grid.inv_resolution();
  row.Bind();
  return row;
}

TEST(RowProjectionTest, RandomRowsOfEveryLengthMatchGridToKey) {
  std::mt19937 rng(7);
  for (const double resolution : {0.01, 0.02, 0.05, 0.37}) {
    const Grid grid(resolution, {0.013, -2.5, 0.7});
    for (int cols = 0; cols <= 13; ++cols) ExpectExact(RandomRow(rng, cols, grid), grid);
    for (int i = 0; i < 200; ++i) ExpectExact(RandomRow(rng, 640, grid), grid);
  }
}

TEST(RowProjectionTest, VoxelBoundariesOnBothSidesOfZeroFloor) {
  // Points exactly on and next to voxel faces, negative and positive: floor, not truncation.
  const Grid grid(0.01);
  Row row;
  const double xs[] = {-0.03, -0.0300001, -0.0299999, -0.01, -1e-12, 0.0, 1e-12, 0.01, 0.0299999};
  for (const double x : xs) {
    for (const double nudge : {0.0, std::nextafter(0.0, 1.0), -std::nextafter(0.0, 1.0)}) {
      row.depth.push_back(1000);  // z = 1 m, so the ray term is the coordinate
      row.rx.push_back(x + nudge);
      row.ry.push_back(-x);
      row.rz.push_back(0.0);
    }
  }
  row.p.scale = 0.001, row.p.min_depth = 0.1, row.p.max_depth = 5.0;
  row.p.inv_resolution = grid.inv_resolution();
  row.Bind();
  ExpectExact(row, grid);
  const Out out = Project(row, false);
  EXPECT_EQ(out.x[0], -3);   // -0.03 / 0.01 = -3 exactly
  EXPECT_EQ(out.x[3], -4);   // -0.0300001
  EXPECT_EQ(out.x[12], -1);  // -1e-12
  EXPECT_EQ(out.x[15], 0);   // 0.0
}

TEST(RowProjectionTest, CoordinatesOutsideTheKeyRangeHaveNoKey) {
  const Grid grid(0.01);
  std::mt19937 rng(3);
  for (const double far : {1e7, -1e7, 1e300}) {
    Row row = RandomRow(rng, 37, grid);
    row.p.ty = far;  // every point out of range on y
    ExpectExact(row, grid);
    const Out out = Project(row, false);
    for (int c = 0; c < row.p.cols; ++c) {
      EXPECT_NE(out.state[c], kRowUse) << "column " << c;
    }
    EXPECT_GT(out.counts.in_range, 0u);
  }
  // A coordinate just inside and just outside the last voxel.
  Row edge;
  const double last = (kMaxKey + 1.0) * 0.01;
  for (const double x :
       {last - 1e-6, last, last + 1e-6, -(kMaxKey + 1.0) * 0.01, -(kMaxKey + 1.0) * 0.01 - 1e-6}) {
    edge.depth.push_back(1000);
    edge.rx.push_back(x), edge.ry.push_back(0), edge.rz.push_back(0);
  }
  edge.p.scale = 0.001, edge.p.min_depth = 0.1, edge.p.max_depth = 5.0;
  edge.p.inv_resolution = grid.inv_resolution();
  edge.Bind();
  ExpectExact(edge, grid);
}

}  // namespace
}  // namespace skimap::perception
