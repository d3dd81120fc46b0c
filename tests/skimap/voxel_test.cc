#include "skimap/voxel.h"

#include <gtest/gtest.h>

#include "skimap/free_columns_voxel.h"
#include "skimap/hypotheses_voxel.h"
#include "skimap/label_voxel.h"

namespace skimap {
namespace {

TEST(RGBWeightedVoxelTest, WeightedMeanAndExactDeintegration) {
  RGBWeightedVoxel v;
  v += RGBWeightedVoxel(255, 0, 0, 1);
  v += RGBWeightedVoxel(0, 0, 255, 3);
  EXPECT_FLOAT_EQ(v.Weight(), 4);
  EXPECT_FLOAT_EQ(v.Red(), 255.0f / 4);
  EXPECT_FLOAT_EQ(v.Blue(), 255.0f * 3 / 4);
  v -= RGBWeightedVoxel(0, 0, 255, 3);
  EXPECT_FLOAT_EQ(v.Red(), 255);
  EXPECT_FLOAT_EQ(v.Blue(), 0);
  EXPECT_FALSE(v.IsEmpty());
  v -= RGBWeightedVoxel(255, 0, 0, 1);
  EXPECT_TRUE(v.IsEmpty());
}

TEST(FreeColumnsVoxelTest, BlocksOfFourByFourColumnsWithExactCounts) {
  // Keys floor to multiples of 4, negative ones too; slots are x major.
  EXPECT_EQ(FreeColumnsVoxel::BlockKey(5, -1), (VoxelKey{4, -4, 0}));
  EXPECT_EQ(FreeColumnsVoxel::BlockKey(-4, 3), (VoxelKey{-4, 0, 0}));
  EXPECT_EQ(FreeColumnsVoxel::Index(5, -1), 1 * 4 + 3);
  FreeColumnsVoxel a, b;
  a.counts[0] = 2;
  a.counts[9] = 1;
  b.counts[9] = 3;
  a += b;
  EXPECT_EQ(a.counts[9], 4u);
  EXPECT_EQ(a.Columns(), 2);
  EXPECT_FLOAT_EQ(a.Weight(), 4);
  a -= b;
  EXPECT_EQ(a.counts[9], 1u);
  b.counts[0] = 5;  // more than a holds: clamps at zero
  a -= b;
  EXPECT_TRUE(a.IsEmpty());
  EXPECT_TRUE(FreeColumnsVoxel().IsEmpty());
}

TEST(FreeColumnsVoxelTest, EncodesTheColumnsItHoldsAndRejectsAListedZero) {
  FreeColumnsVoxel v;
  v.counts[3] = 7;
  v.counts[12] = 70000;
  std::string bytes;
  Encoder e(&bytes);
  v.Encode(e);
  EXPECT_EQ(bytes.size(), 2u + 2 * 4);  // the mask, then two counts
  FreeColumnsVoxel back;
  Decoder d(bytes);
  ASSERT_TRUE(FreeColumnsVoxel::Decode(d, &back));
  EXPECT_EQ(back, v);
  std::string zero = bytes;
  zero[2] = zero[3] = zero[4] = zero[5] = 0;  // slot 3 listed with a count of 0
  Decoder dz(zero);
  EXPECT_FALSE(FreeColumnsVoxel::Decode(dz, &back));
  Decoder short_input(std::string_view(bytes).substr(0, 7));
  EXPECT_FALSE(FreeColumnsVoxel::Decode(short_input, &back));
}

TEST(FreeColumnsVoxelTest, FoldsAColumnOfTheOldVolumeIntoItsBlock) {
  VoxelKey block;
  FreeColumnsVoxel v;
  ASSERT_TRUE(FreeColumnsVoxel::FromLegacy({-3, 6, 0}, WeightVoxel{5}, &block, &v));
  EXPECT_EQ(block, (VoxelKey{-4, 4, 0}));
  EXPECT_EQ(v.counts[size_t(FreeColumnsVoxel::Index(-3, 6))], 5u);
  EXPECT_EQ(v.Columns(), 1);
  // What the old volume never held: another layer, a fraction, nothing.
  EXPECT_FALSE(FreeColumnsVoxel::FromLegacy({0, 0, 1}, WeightVoxel{1}, &block, &v));
  EXPECT_FALSE(FreeColumnsVoxel::FromLegacy({0, 0, 0}, WeightVoxel{1.5f}, &block, &v));
  EXPECT_FALSE(FreeColumnsVoxel::FromLegacy({0, 0, 0}, WeightVoxel{0}, &block, &v));
}

TEST(MultiLabelVoxelTest, MergeIsLosslessPerLabel) {  // Eq. 4-5
  MultiLabelVoxel a(7, 2);
  a += MultiLabelVoxel(3, 1);
  a += MultiLabelVoxel(7, 1);
  MultiLabelVoxel b(3, 4);
  b += MultiLabelVoxel(9, 1);
  MultiLabelVoxel sum = a;
  sum += b;
  EXPECT_EQ(sum.Count(3), 5u);
  EXPECT_EQ(sum.Count(7), 3u);
  EXPECT_EQ(sum.Count(9), 1u);
  EXPECT_FLOAT_EQ(sum.Weight(), 9);
  sum -= b;
  EXPECT_EQ(sum, a);
  ASSERT_EQ(sum.entries().size(), 2u);
  EXPECT_LT(sum.entries()[0].label, sum.entries()[1].label);
}

TEST(MultiLabelVoxelTest, SubtractClampsAtZeroAndDropsLabels) {
  MultiLabelVoxel v(1, 2);
  v += MultiLabelVoxel(2, 1);
  v -= MultiLabelVoxel(1, 5);
  EXPECT_EQ(v.Count(1), 0u);
  EXPECT_EQ(v.entries().size(), 1u);
  v -= MultiLabelVoxel(4, 1);  // absent label: no effect
  EXPECT_EQ(v.Count(2), 1u);
  v -= MultiLabelVoxel(2, 1);
  EXPECT_TRUE(v.IsEmpty());
}

TEST(MultiLabelVoxelTest, HeaviestPicksLargestCountThenSmallestLabel) {
  MultiLabelVoxel v;
  EXPECT_EQ(v.Heaviest().count, 0u);
  v += MultiLabelVoxel(9, 3);
  v += MultiLabelVoxel(4, 3);
  v += MultiLabelVoxel(5, 1);
  EXPECT_EQ(v.Heaviest().label, 4u);
  EXPECT_EQ(v.Heaviest().count, 3u);
  v += MultiLabelVoxel(5, 3);
  EXPECT_EQ(v.Heaviest().label, 5u);
}

TEST(HypothesesVoxelTest, IsASetOfPoses) {
  Hypothesis h1{{1, 2, 3}, {1, 0, 0, 0}, 4, 0.5f};
  Hypothesis h2{{1, 2, 3}, {0, 1, 0, 0}, 4, 0.25f};
  HypothesesVoxel v(h1);
  v += HypothesesVoxel(h1);  // already present
  v += HypothesesVoxel(h2);
  EXPECT_EQ(v.items().size(), 2u);
  EXPECT_FLOAT_EQ(v.Weight(), 0.75f);
  v -= HypothesesVoxel(h1);
  ASSERT_EQ(v.items().size(), 1u);
  EXPECT_EQ(v.items()[0], h2);
  v -= HypothesesVoxel(h2);
  EXPECT_TRUE(v.IsEmpty());
}

TEST(InstancesVoxelTest, NewestEstimatePerIdWins) {
  Instance a{.id = 1, .object_id = 3, .t = {0, 0, 0}, .score = 1, .support = 5};
  Instance a2 = a;
  a2.t = {0.01f, 0, 0};
  a2.support = 9;
  Instance b{.id = 2, .object_id = 3};
  InstancesVoxel v(a);
  v += InstancesVoxel(b);
  v += InstancesVoxel(a2);
  ASSERT_EQ(v.items().size(), 2u);
  EXPECT_EQ(v.items()[0], a2);
  v -= InstancesVoxel(a);  // removal is by id
  ASSERT_EQ(v.items().size(), 1u);
  EXPECT_EQ(v.items()[0].id, 2u);
}

}  // namespace
}  // namespace skimap
