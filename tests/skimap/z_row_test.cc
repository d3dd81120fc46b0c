// ZRow, the z level of one (x, y) column: batches merged into the sorted run against a
// std::map model (new keys before, between and after the old ones, voxels emptied by a
// write, empty data), and its memory returned to the pool.
#include "skimap/z_row.h"

#include <gtest/gtest.h>

#include <map>
#include <random>
#include <vector>

#include "skimap/label_voxel.h"
#include "skimap/voxel.h"
#include "skimap/voxel_batch.h"

namespace skimap {
namespace {

using Item = VoxelBatch<WeightVoxel>::Item;

std::map<int32_t, float> Contents(const ZRow<WeightVoxel>& row) {
  std::map<int32_t, float> out;
  int32_t prev = 0;
  for (const auto& e : row) {
    EXPECT_TRUE(out.empty() || prev < e.key) << "keys must ascend";
    prev = e.key;
    out[e.key] = e.value.weight;
  }
  return out;
}

TEST(ZRowTest, RandomBatchesMatchAMapModel) {
  NodePool pool;
  ZRow<WeightVoxel> row;
  std::map<int32_t, float> model;
  std::mt19937 rng(7);
  size_t heap = 0;
  for (int step = 0; step < 400; ++step) {
    // A sorted batch of distinct z over a range that overlaps the row's keys on both
    // sides; some weights negative (a write that empties a voxel), some zero (empty data).
    std::map<int32_t, float> batch;
    const int n = 1 + static_cast<int>(rng() % 40);
    for (int i = 0; i < n; ++i) {
      const int32_t z = static_cast<int32_t>(rng() % 120) - 60;
      const int kind = static_cast<int>(rng() % 10);
      batch[z] = kind == 0 ? 0.0f : kind == 1 ? -2.0f : 1.0f + static_cast<float>(rng() % 3);
    }
    std::vector<Item> items;
    for (const auto& [z, w] : batch) items.push_back({{0, 0, z}, WeightVoxel{w}});
    const bool add = rng() % 4 != 0;
    WriteStats stats;
    size_t created = 0, removed = 0, touched = 0;
    for (const auto& [z, w] : batch) {
      auto it = model.find(z);
      if (add) {
        ++touched;
        if (it == model.end()) {
          ++created;
          if (w <= kEmptyWeight) {
            ++removed;
          } else {
            model[z] = w;
          }
        } else if ((it->second += w) <= kEmptyWeight) {
          model.erase(it);
          ++removed;
        }
      } else if (it != model.end()) {
        ++touched;
        if ((it->second -= w) <= kEmptyWeight) {
          model.erase(it);
          ++removed;
        }
      }
    }
    if (add) {
      row.Integrate(pool, items.data(), items.data() + items.size(), &stats, &heap);
    } else {
      row.Deintegrate(pool, items.data(), items.data() + items.size(), &stats, &heap);
    }
    ASSERT_EQ(Contents(row), model) << "step " << step;
    EXPECT_EQ(stats.voxels_touched, touched);
    EXPECT_EQ(stats.voxels_created, created);
    EXPECT_EQ(stats.voxels_removed, removed);
    for (const auto& [z, w] : model) {
      const auto* e = row.Find(z);
      ASSERT_NE(e, nullptr);
      EXPECT_EQ(e->value.weight, w);
      EXPECT_EQ(row.Find(z + 1000), nullptr);
    }
  }
  EXPECT_EQ(heap, 0u);
  row.Clear(pool);
  EXPECT_EQ(pool.BytesInUse(), 0u);
}

TEST(ZRowTest, AnEmptiedRowFreesItsBlockAndHeapBytesAreCounted) {
  NodePool pool;
  ZRow<MultiLabelVoxel> row;
  using LabelItem = VoxelBatch<MultiLabelVoxel>::Item;
  std::vector<LabelItem> items;
  for (int32_t z = 0; z < 100; z += 3) items.push_back({{0, 0, z}, MultiLabelVoxel(z % 5, 2)});
  size_t heap = 0;
  WriteStats stats;
  row.Integrate(pool, items.data(), items.data() + items.size(), &stats, &heap);
  EXPECT_EQ(row.size(), items.size());
  // Three more labels per voxel spill the inline storage: HeapBytes grows, and is counted.
  std::vector<LabelItem> more = items;
  for (uint32_t label : {7u, 8u, 9u}) {
    for (LabelItem& it : more) it.data = MultiLabelVoxel(label, 1);
    row.Integrate(pool, more.data(), more.data() + more.size(), &stats, &heap);
  }
  size_t expected_heap = 0;
  for (const auto& e : row) expected_heap += e.value.HeapBytes();
  EXPECT_GT(expected_heap, 0u);
  EXPECT_EQ(heap, expected_heap);
  // Subtracting everything empties every voxel: the row frees its block.
  row.Deintegrate(pool, items.data(), items.data() + items.size(), &stats, &heap);
  for (uint32_t label : {7u, 8u, 9u}) {
    for (LabelItem& it : more) it.data = MultiLabelVoxel(label, 1);
    row.Deintegrate(pool, more.data(), more.data() + more.size(), &stats, &heap);
  }
  EXPECT_TRUE(row.empty());
  EXPECT_EQ(heap, 0u);
  EXPECT_EQ(pool.BytesInUse(), 0u);
}

}  // namespace
}  // namespace skimap
