// YRow, the y level of one x column: batches of (y, z) items merged into the sorted run of
// rows against a std::map model (new rows before, between and after the old ones, rows
// and voxels emptied by a write, empty data, de-integration), and its memory returned.
#include "skimap/y_row.h"

#include <gtest/gtest.h>

#include <map>
#include <random>
#include <set>
#include <utility>
#include <vector>

#include "skimap/voxel.h"
#include "skimap/voxel_batch.h"

namespace skimap {
namespace {

using Item = VoxelBatch<WeightVoxel>::Item;
using Key = std::pair<int32_t, int32_t>;  // (y, z)

std::map<Key, float> Contents(const YRow<WeightVoxel>& ys) {
  std::map<Key, float> out;
  const YRow<WeightVoxel>::Entry* prev = nullptr;
  for (const auto& row : ys) {
    EXPECT_TRUE(prev == nullptr || prev->key < row.key) << "y keys must ascend";
    EXPECT_FALSE(row.value.empty()) << "an empty row must be removed";
    prev = &row;
    for (const auto& e : row.value) out[{row.key, e.key}] = e.value.weight;
  }
  return out;
}

TEST(YRowTest, RandomBatchesMatchAMapModel) {
  NodePool pool;
  YRow<WeightVoxel> ys;
  std::map<Key, float> model;
  std::mt19937 rng(11);
  size_t heap = 0;
  for (int step = 0; step < 600; ++step) {
    // Rows over a y range wider than what a batch covers, so batches add rows before,
    // between and after the old ones; some weights negative, some zero (empty data).
    std::map<Key, float> batch;
    const int rows = 1 + static_cast<int>(rng() % 12);
    const int32_t y_base = static_cast<int32_t>(rng() % 80) - 40;
    for (int r = 0; r < rows; ++r) {
      const int32_t y = y_base + static_cast<int32_t>(rng() % 30);
      const int n = 1 + static_cast<int>(rng() % 6);
      for (int i = 0; i < n; ++i) {
        const int32_t z = static_cast<int32_t>(rng() % 20) - 10;
        const int kind = static_cast<int>(rng() % 10);
        batch[{y, z}] = kind == 0 ? 0.0f : kind == 1 ? -2.0f : 1.0f + static_cast<float>(rng() % 3);
      }
    }
    std::vector<Item> items;
    for (const auto& [k, w] : batch) items.push_back({{0, k.first, k.second}, WeightVoxel{w}});
    std::set<int32_t> rows_before;
    for (const auto& [k, w] : model) rows_before.insert(k.first);
    const bool add = rng() % 4 != 0;
    size_t created = 0, removed = 0, touched = 0;
    for (const auto& [k, w] : batch) {
      auto it = model.find(k);
      if (add) {
        ++touched;
        if (it == model.end()) {
          // A voxel of an existing row with empty data is created and removed at once; a
          // new row takes only the voxels with data.
          if (w > kEmptyWeight) {
            ++created;
            model[k] = w;
          } else if (rows_before.count(k.first) > 0) {
            ++created;
            ++removed;
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
    WriteStats stats;
    if (add) {
      ys.Integrate(pool, items.data(), items.data() + items.size(), &stats, &heap);
    } else {
      ys.Deintegrate(pool, items.data(), items.data() + items.size(), &stats, &heap);
    }
    ASSERT_EQ(Contents(ys), model) << "step " << step;
    EXPECT_EQ(stats.voxels_touched, touched) << "step " << step;
    EXPECT_EQ(stats.voxels_created, created) << "step " << step;
    EXPECT_EQ(stats.voxels_removed, removed) << "step " << step;
    for (const auto& [k, w] : model) {
      const auto* row = ys.Find(k.first);
      ASSERT_NE(row, nullptr);
      const auto* e = row->value.Find(k.second);
      ASSERT_NE(e, nullptr);
      EXPECT_EQ(e->value.weight, w);
    }
    EXPECT_EQ(ys.Find(1000), nullptr);
  }
  EXPECT_EQ(heap, 0u);
  ys.Clear(pool);
  EXPECT_EQ(pool.BytesInUse(), 0u);
}

TEST(YRowTest, DeintegratingEverythingFreesEveryBlock) {
  NodePool pool;
  YRow<WeightVoxel> ys;
  std::vector<Item> items;
  // 700 rows: the y run outgrows the pool's largest block and comes from the heap.
  for (int32_t y = -700; y < 700; y += 2) {
    for (int32_t z = 0; z < 3; ++z) items.push_back({{0, y, z}, WeightVoxel{1}});
  }
  size_t heap = 0;
  WriteStats stats;
  ys.Integrate(pool, items.data(), items.data() + items.size(), &stats, &heap);
  EXPECT_EQ(ys.size(), 700u);
  EXPECT_EQ(stats.voxels_created, items.size());
  EXPECT_GT(pool.BytesInUse(), YRow<WeightVoxel>::Bytes(700));
  ys.Deintegrate(pool, items.data(), items.data() + items.size(), &stats, &heap);
  EXPECT_TRUE(ys.empty());
  EXPECT_EQ(stats.voxels_removed, items.size());
  EXPECT_EQ(pool.BytesInUse(), 0u);
}

}  // namespace
}  // namespace skimap
