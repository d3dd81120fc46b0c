#include "skimap/skimap.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <random>
#include <stdexcept>
#include <vector>

#include "skimap/label_voxel.h"

namespace skimap {
namespace {

using Model = std::map<VoxelKey, float>;  // reference: key -> weight

Model Snapshot(const SkiMap<WeightVoxel>& map) {
  Model out;
  VoxelKey prev{kMinKey, kMinKey, kMinKey};
  bool first = true;
  map.ForEach([&](const VoxelKey& k, const WeightVoxel& v) {
    EXPECT_TRUE(first || prev < k) << "ForEach must visit keys in ascending order";
    first = false;
    prev = k;
    out[k] = v.weight;
  });
  return out;
}

void ExpectSameAs(const SkiMap<WeightVoxel>& map, const Model& model) {
  EXPECT_EQ(map.size(), model.size());
  EXPECT_EQ(Snapshot(map), model);
}

// Applies `+= w` to the model the way the map does: empty voxels disappear.
void ModelAdd(Model& m, const VoxelKey& k, float w) {
  float& v = m[k];
  v += w;
  if (v <= kEmptyWeight) m.erase(k);
}
void ModelSub(Model& m, const VoxelKey& k, float w) {
  auto it = m.find(k);
  if (it == m.end()) return;
  it->second -= w;
  if (it->second <= kEmptyWeight) m.erase(it);
}

TEST(SkiMapTest, KeysUseFloorSemanticsForNegativeCoordinates) {
  Grid g(0.05);
  VoxelKey k;
  ASSERT_TRUE(g.ToKey(-0.001, 0.0, 0.049, &k));
  EXPECT_EQ(k, (VoxelKey{-1, 0, 0}));
  ASSERT_TRUE(g.ToKey(-0.05, -0.0500001, 0.05, &k));
  EXPECT_EQ(k, (VoxelKey{-1, -2, 1}));
  Grid shifted(0.1, {1.0, -2.0, 0.5});
  ASSERT_TRUE(shifted.ToKey(0.95, -2.05, 0.5, &k));
  EXPECT_EQ(k, (VoxelKey{-1, -1, 0}));
  const Point3 c = shifted.Center(k);
  EXPECT_NEAR(c.x, 0.95, 1e-12);
  EXPECT_NEAR(c.y, -2.05, 1e-12);
  EXPECT_NEAR(c.z, 0.55, 1e-12);
}

TEST(SkiMapTest, KeyRangeEdgesAreRejectedNotWrapped) {
  Grid g(1.0);
  VoxelKey k;
  EXPECT_TRUE(g.ToKey(kMaxKey + 0.999, kMinKey, 0, &k));
  EXPECT_EQ(k.x, kMaxKey);
  EXPECT_EQ(k.y, kMinKey);
  EXPECT_FALSE(g.ToKey(kMaxKey + 1.0, 0, 0, &k));
  EXPECT_FALSE(g.ToKey(0, kMinKey - 0.001, 0, &k));
  EXPECT_FALSE(g.ToKey(0, 0, NAN, &k));
  EXPECT_FALSE(g.ToKey(INFINITY, 0, 0, &k));

  SkiMap<WeightVoxel> map({.resolution = 1.0});
  EXPECT_EQ(map.Integrate({1e9, 0, 0}, WeightVoxel{1}).code(), absl::StatusCode::kInvalidArgument);
  EXPECT_TRUE(map.empty());
  VoxelBatch<WeightVoxel> batch;
  EXPECT_FALSE(batch.Add(map.grid(), 0, -1e9, 0, WeightVoxel{1}));
  EXPECT_TRUE(batch.Add(map.grid(), kMinKey, kMaxKey, 0, WeightVoxel{1}));
  EXPECT_EQ(batch.rejected(), 1u);
  batch.Finalize();
  map.Integrate(batch);
  // Extreme keys survive the tree and the box query.
  ASSERT_TRUE(map.Find({kMinKey, kMaxKey, 0}).has_value());
  const std::optional<KeyBox> b = map.Bounds();
  ASSERT_TRUE(b.has_value());
  EXPECT_EQ(b->min.x, kMinKey);
  EXPECT_EQ(b->max.y, kMaxKey);
}

TEST(SkiMapTest, RandomOperationsMatchReferenceModel) {
  for (uint32_t seed : {3u, 99u}) {
    ThreadPool pool(1);
    SkiMap<WeightVoxel> map({.resolution = 0.1, .lists = {.seed = seed}, .pool = &pool});
    Model model;
    std::mt19937 rng(seed);
    std::uniform_int_distribution<int> coord(-12, 12);
    auto random_key = [&] { return VoxelKey{coord(rng), coord(rng), coord(rng)}; };
    for (int step = 0; step < 3000; ++step) {
      const int op = rng() % 6;
      if (op == 0) {
        const VoxelKey k = random_key();
        const float w = 1 + rng() % 3;
        map.IntegrateKey(k, WeightVoxel{w});
        ModelAdd(model, k, w);
      } else if (op == 1) {
        const VoxelKey k = random_key();
        const float w = 1 + rng() % 3;
        map.DeintegrateKey(k, WeightVoxel{w});
        ModelSub(model, k, w);
      } else if (op == 2) {
        const VoxelKey k = random_key();
        EXPECT_EQ(map.Erase(k), model.erase(k) == 1);
      } else if (op == 3) {
        // A batch large enough to run in parallel, with duplicates and negative keys.
        VoxelBatch<WeightVoxel> batch;
        const bool add = rng() % 3 != 0;
        std::map<VoxelKey, float> sums;
        for (int i = 0; i < 6000; ++i) {
          const VoxelKey k = random_key();
          batch.AddKey(k, WeightVoxel{1});
          sums[k] += 1;
        }
        batch.Finalize();
        ASSERT_EQ(batch.size(), sums.size());
        if (add) {
          map.Integrate(batch);
          for (auto& [k, w] : sums) ModelAdd(model, k, w);
        } else {
          map.Deintegrate(batch);
          for (auto& [k, w] : sums) ModelSub(model, k, w);
        }
      } else if (op == 4) {
        KeyBox box{random_key(), random_key()};
        std::vector<std::pair<VoxelKey, float>> expected, got;  // in (x, y, z) order
        for (auto& [k, w] : model) {
          if (box.Contains(k)) expected.emplace_back(k, w);
        }
        map.ForEachInBox(
            box, [&](const VoxelKey& k, const WeightVoxel& v) { got.emplace_back(k, v.weight); });
        EXPECT_EQ(got, expected);
      } else {
        const Point3 c{coord(rng) * 0.1, coord(rng) * 0.1, coord(rng) * 0.1};
        const double r = (rng() % 100) * 0.01;
        Model expected;
        for (auto& [k, w] : model) {
          const Point3 p = map.grid().Center(k);
          const double d2 =
              (p.x - c.x) * (p.x - c.x) + (p.y - c.y) * (p.y - c.y) + (p.z - c.z) * (p.z - c.z);
          if (d2 <= r * r) expected[k] = w;
        }
        // In (x, y, z) order, each voxel once: the same sequence as the sorted model's.
        std::vector<std::pair<VoxelKey, float>> got_in_order;
        map.RadiusSearch(c, r, [&](const VoxelKey& k, const WeightVoxel& v) {
          got_in_order.emplace_back(k, v.weight);
        });
        const std::vector<std::pair<VoxelKey, float>> expected_in_order(expected.begin(),
                                                                        expected.end());
        EXPECT_EQ(got_in_order, expected_in_order) << "radius " << r;
      }
      if (step % 500 == 0) ExpectSameAs(map, model);
    }
    ExpectSameAs(map, model);
  }
}

TEST(SkiMapTest, EmptyDataCreatesNoVoxels) {
  // Zero-weight observations in a new column, in a new (x, y) of an existing column and
  // next to real ones: only the real ones become voxels.
  SkiMap<WeightVoxel> map({.resolution = 0.1});
  const size_t empty_bytes = map.MemoryUsage();
  VoxelBatch<WeightVoxel> first;
  first.AddKey({0, 0, 0}, WeightVoxel{0});
  first.AddKey({0, 1, 0}, WeightVoxel{1});
  first.AddKey({0, 1, 1}, WeightVoxel{0});
  first.AddKey({1, 0, 0}, WeightVoxel{0});
  first.Finalize();
  EXPECT_EQ(map.Integrate(first).voxels_created, 1u);
  VoxelBatch<WeightVoxel> second;
  second.AddKey({0, 5, 0}, WeightVoxel{0});
  second.AddKey({0, 6, 0}, WeightVoxel{2});
  second.AddKey({0, 7, 3}, WeightVoxel{0});
  second.Finalize();
  map.Integrate(second);
  std::vector<VoxelKey> keys;
  map.ForEach([&](const VoxelKey& k, const WeightVoxel& v) {
    EXPECT_FALSE(v.IsEmpty());
    keys.push_back(k);
  });
  EXPECT_EQ(keys, (std::vector<VoxelKey>{{0, 1, 0}, {0, 6, 0}}));
  EXPECT_EQ(map.size(), 2u);
  ASSERT_TRUE(map.Bounds().has_value());
  EXPECT_EQ(map.Bounds()->max.y, 6);
  map.DeintegrateKey({0, 1, 0}, WeightVoxel{1});
  map.DeintegrateKey({0, 6, 0}, WeightVoxel{2});
  EXPECT_TRUE(map.empty());
  EXPECT_EQ(map.MemoryUsage(), empty_bytes);
}

TEST(SkiMapTest, ThrowingRadiusCallbackReleasesTheLocks) {
  SkiMap<WeightVoxel> map({.resolution = 0.1});
  for (int x = -20; x <= 20; ++x) map.IntegrateKey({x, 0, 0}, WeightVoxel{1});
  EXPECT_THROW(map.RadiusSearch({0, 0, 0}, 3.0,
                                [](const VoxelKey& k, const WeightVoxel&) {
                                  if (k.x == 5) throw std::runtime_error("stop");
                                }),
               std::runtime_error);
  // A writer needs every column lock back (it would block forever otherwise).
  for (int x = -20; x <= 20; ++x) map.DeintegrateKey({x, 0, 0}, WeightVoxel{1});
  EXPECT_TRUE(map.empty());
}

TEST(SkiMapTest, SearchesOverManyColumnGroupsMatchBruteForce) {
  // 160 x columns: one radius search spans several groups of columns, with tall and short
  // z lists (walls and floor) and empty columns between.
  SkiMap<WeightVoxel> map({.resolution = 0.05});
  std::map<VoxelKey, float> model;
  std::mt19937 rng(11);
  VoxelBatch<WeightVoxel> batch;
  for (int i = 0; i < 60000; ++i) {
    const int x = static_cast<int>(rng() % 160) - 80;
    if (x % 7 == 0) continue;  // columns left empty
    const int y = static_cast<int>(rng() % 120) - 60;
    const int z = (y % 10 == 0) ? static_cast<int>(rng() % 60) : static_cast<int>(rng() % 3);
    const VoxelKey k{x, y, z};
    batch.AddKey(k, WeightVoxel{1});
    model[k] += 1;
  }
  batch.Finalize();
  map.Integrate(batch);
  for (int q = 0; q < 40; ++q) {
    const Point3 c{(static_cast<int>(rng() % 200) - 100) * 0.05,
                   (static_cast<int>(rng() % 160) - 80) * 0.05, (rng() % 40) * 0.05};
    const double r = 0.1 + (rng() % 300) * 0.01;
    std::vector<std::pair<VoxelKey, float>> expected, got;
    for (const auto& [k, w] : model) {
      const Point3 p = map.grid().Center(k);
      const double d2 =
          (p.x - c.x) * (p.x - c.x) + (p.y - c.y) * (p.y - c.y) + (p.z - c.z) * (p.z - c.z);
      if (d2 <= r * r) expected.emplace_back(k, w);
    }
    map.RadiusSearch(
        c, r, [&](const VoxelKey& k, const WeightVoxel& v) { got.emplace_back(k, v.weight); });
    EXPECT_EQ(got, expected) << "query " << q << " radius " << r;
  }
  // Boxes narrower and wider than the interleaved search's limit (1 024 keys in y).
  for (const KeyBox& box :
       {KeyBox{{-70, -20, 1}, {75, 31, 40}}, KeyBox{{-30, -2000, 0}, {60, 2000, 2}}}) {
    std::vector<std::pair<VoxelKey, float>> expected, got;
    for (const auto& [k, w] : model) {
      if (box.Contains(k)) expected.emplace_back(k, w);
    }
    map.ForEachInBox(
        box, [&](const VoxelKey& k, const WeightVoxel& v) { got.emplace_back(k, v.weight); });
    EXPECT_EQ(got, expected);
    EXPECT_FALSE(got.empty());
  }
}

TEST(SkiMapTest, FindReturnsTheFusedValue) {
  SkiMap<RGBWeightedVoxel> map({.resolution = 0.02});
  ASSERT_TRUE(map.Integrate({0.011, -0.5, 1.0}, RGBWeightedVoxel(200, 100, 0, 1)).ok());
  ASSERT_TRUE(map.Integrate({0.019, -0.499, 1.001}, RGBWeightedVoxel(100, 100, 100, 1)).ok());
  VoxelKey k;
  ASSERT_TRUE(map.grid().ToKey(0.015, -0.49, 1.01, &k));
  const std::optional<RGBWeightedVoxel> v = map.Find(k);
  ASSERT_TRUE(v.has_value());
  EXPECT_FLOAT_EQ(v->Weight(), 2);
  EXPECT_FLOAT_EQ(v->Red(), 150);
  EXPECT_FLOAT_EQ(v->Blue(), 50);
  EXPECT_FALSE(map.Find({k.x + 1, k.y, k.z}).has_value());
}

TEST(SkiMapTest, DeintegrationRestoresTheEmptyMapAndFreesMemory) {
  ThreadPool pool(1);
  SkiMap<RGBWeightedVoxel> map({.resolution = 0.01, .pool = &pool});
  const size_t empty_bytes = map.MemoryUsage();
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-2, 2);
  std::vector<VoxelBatch<RGBWeightedVoxel>> frames(4);
  for (auto& batch : frames) {
    for (int i = 0; i < 50000; ++i) {
      batch.Add(map.grid(), u(rng), u(rng), u(rng) * 0.1, RGBWeightedVoxel(10, 20, 30, 1));
    }
    batch.Finalize();
    map.Integrate(batch);
  }
  const size_t full_bytes = map.MemoryUsage();
  // Measured 2026-11-23: 936 B empty, 11 842 680 B full (200 000 random points); the floor
  // is two thirds of the full map.
  EXPECT_GT(full_bytes, empty_bytes + 7900000);
  for (auto& batch : frames) map.Deintegrate(batch);
  EXPECT_TRUE(map.empty());
  EXPECT_EQ(map.MemoryUsage(), empty_bytes);
  EXPECT_FALSE(map.Bounds().has_value());
  // Memory is reused: a second fill costs no more than the first.
  for (auto& batch : frames) map.Integrate(batch);
  // (Measured equal to the first fill; 5 % leaves room for random tower heights.)
  EXPECT_LE(map.MemoryUsage(), full_bytes + full_bytes / 20);
}

TEST(SkiMapTest, ParallelAndSerialBatchesGiveTheSameMap) {
  ThreadPool pool(3);
  SkiMap<WeightVoxel> parallel({.resolution = 0.05, .pool = &pool});
  SkiMap<WeightVoxel> serial({.resolution = 0.05});
  std::mt19937 rng(8);
  std::normal_distribution<double> n(0, 1.5);
  VoxelBatch<WeightVoxel> batch;
  for (int i = 0; i < 200000; ++i) batch.Add(serial.grid(), n(rng), n(rng), n(rng), {1});
  batch.Finalize();
  const WriteStats a = parallel.Integrate(batch);
  const WriteStats b = serial.Integrate(batch);
  EXPECT_EQ(a.voxels_created, b.voxels_created);
  EXPECT_EQ(a.voxels_created, batch.size());
  EXPECT_EQ(Snapshot(parallel), Snapshot(serial));
  double total = 0;
  parallel.ForEach([&](const VoxelKey&, const WeightVoxel& v) { total += v.weight; });
  EXPECT_DOUBLE_EQ(total, 200000 - batch.rejected());
}

TEST(VoxelBatchTest, CopyItemsFromCopiesTheItemsAndTheirStateOnly) {
  const Grid grid(0.1);
  VoxelBatch<WeightVoxel> built, sealed;
  for (int i = 0; i < 1000; ++i) built.Add(grid, 0.01 * i, 0, 0, {1});
  EXPECT_FALSE(built.Add(grid, NAN, 0, 0, {1}));
  built.Finalize();
  sealed.Add(grid, 5, 5, 5, {3});  // replaced, not kept
  sealed.CopyItemsFrom(built);
  ASSERT_EQ(sealed.size(), built.size());
  EXPECT_EQ(sealed.size(), 100u);
  EXPECT_TRUE(sealed.finalized());
  EXPECT_EQ(sealed.rejected(), 1u);
  for (size_t i = 0; i < built.size(); ++i) {
    EXPECT_EQ(sealed.items()[i].key, built.items()[i].key);
    EXPECT_EQ(sealed.items()[i].data.weight, built.items()[i].data.weight);
  }
  // The source builds on unchanged; an unfinalized source gives an unfinalized copy.
  built.Clear();
  built.Add(grid, 1, 1, 1, {2});
  built.Add(grid, 0, 0, 0, {2});
  sealed.CopyItemsFrom(built);
  EXPECT_EQ(sealed.size(), 2u);
  EXPECT_FALSE(sealed.finalized());
  sealed.Finalize();
  EXPECT_LT(sealed.items()[0].key, sealed.items()[1].key);
}

// AddRows merges a row's runs into earlier items of the same key (the rows above), not only
// consecutive equal keys: Finalize then sorts far fewer items, and the result is the same.
TEST(VoxelBatchTest, AddRowsMergesRepeatedKeysAcrossRows) {
  constexpr size_t kRows = 256, kCols = 128;  // enough points for the pool to split them
  // Voxels of 8 x 8 pixels, and every 5th pixel of a row in a voxel of its own row band
  // at z = 1, so that runs are short and keys come back within a row too.
  auto key_of = [](size_t r, size_t c) {
    return VoxelKey{int32_t(c / 8), int32_t(r / 8), c % 5 == 0 ? 1 : 0};
  };
  auto fill = [&](size_t r, VoxelBatch<RGBWeightedVoxel>::KeyRow row, RGBWeightedVoxel* d) {
    for (size_t c = 0; c < kCols; ++c) {
      const VoxelKey k = key_of(r, c);
      row.x[c] = k.x, row.y[c] = k.y, row.z[c] = k.z;
      row.state[c] = (r + c) % 11 == 0 ? VoxelBatch<RGBWeightedVoxel>::kSkip
                                       : VoxelBatch<RGBWeightedVoxel>::kUse;
      d[c] = RGBWeightedVoxel(float((r * 7 + c) % 256), 1, 2, 1);
    }
  };
  VoxelBatch<RGBWeightedVoxel> reference;
  for (size_t r = 0; r < kRows; ++r) {
    for (size_t c = 0; c < kCols; ++c) {
      if ((r + c) % 11 == 0) continue;
      reference.AddKey(key_of(r, c), RGBWeightedVoxel(float((r * 7 + c) % 256), 1, 2, 1));
    }
  }
  reference.Finalize();
  ASSERT_EQ(reference.size(), 16u * 32u * 2u);
  ThreadPool pool(2);
  VoxelBatch<RGBWeightedVoxel> batch;  // reused across rounds, as a map's stage reuses it
  for (ThreadPool* p : {static_cast<ThreadPool*>(nullptr), &pool, &pool}) {
    batch.Clear();
    batch.AddRows(kRows, kCols, fill, p);
    // Without the merge across rows: over 13 000 runs (each row has more than 50).
    EXPECT_LE(batch.size(), 2 * reference.size()) << (p != nullptr);
    batch.Finalize(p);
    ASSERT_EQ(batch.size(), reference.size());
    for (size_t i = 0; i < batch.size(); ++i) {
      const auto& a = batch.items()[i];
      const auto& b = reference.items()[i];
      ASSERT_EQ(a.key, b.key) << i;
      EXPECT_EQ(a.data.weight, b.data.weight) << i;
      EXPECT_EQ(a.data.r, b.data.r) << i;  // integer sums: exact in any order
    }
  }
}

TEST(VoxelBatchTest, ParallelAddAndFinalizeMatchSerial) {
  ThreadPool pool(2);
  const Grid grid(0.02, {-0.5, 0.25, 0});
  std::mt19937 rng(17);
  std::normal_distribution<double> n(0, 2);
  std::vector<Point3> points(300000);
  for (Point3& p : points) p = {n(rng), n(rng), n(rng) * 0.3};
  points[1234].x = NAN;    // rejected
  points[99999].y = 1e12;  // rejected
  auto get = [&](size_t i, Point3* p, RGBWeightedVoxel* d) {
    if (i % 97 == 0) return false;  // skipped, as a pixel without depth
    *p = points[i];
    *d = RGBWeightedVoxel(i % 256, 0, 0, 1);
    return true;
  };
  VoxelBatch<RGBWeightedVoxel> serial, parallel;
  serial.AddPoints(grid, points.size(), get);
  parallel.AddPoints(grid, points.size(), get, &pool);
  EXPECT_EQ(serial.rejected(), 2u);
  EXPECT_EQ(parallel.rejected(), 2u);
  serial.Finalize();
  parallel.Finalize(&pool);
  ASSERT_EQ(serial.size(), parallel.size());
  ASSERT_TRUE(serial.finalized() && parallel.finalized());
  double weight = 0;
  for (size_t i = 0; i < serial.size(); ++i) {
    const auto& a = serial.items()[i];
    const auto& b = parallel.items()[i];
    ASSERT_EQ(a.key, b.key) << i;
    EXPECT_FLOAT_EQ(a.data.weight, b.data.weight);
    EXPECT_NEAR(a.data.r, b.data.r, 1e-3 * a.data.r + 1e-3);  // summation order differs
    if (i > 0) ASSERT_LT(serial.items()[i - 1].key, a.key);
    weight += a.data.weight;
  }
  size_t skipped = 0;
  for (size_t i = 0; i < points.size(); ++i) skipped += i % 97 == 0;
  EXPECT_EQ(weight, double(points.size() - skipped - 2));
}

TEST(SkiMapTest, MultiLabelVoxelsFuseAndEmptyOut) {
  SkiMap<MultiLabelVoxel> map({.resolution = 0.01});
  ASSERT_TRUE(map.Integrate({0, 0, 0}, MultiLabelVoxel(4, 2)).ok());
  ASSERT_TRUE(map.Integrate({0, 0, 0}, MultiLabelVoxel(6, 3)).ok());
  std::optional<MultiLabelVoxel> v = map.Find({0, 0, 0});
  ASSERT_TRUE(v.has_value());
  EXPECT_EQ(v->Heaviest().label, 6u);
  EXPECT_GT(map.MemoryUsage(), 0u);
  ASSERT_TRUE(map.Deintegrate({0, 0, 0}, MultiLabelVoxel(6, 3)).ok());
  EXPECT_EQ(map.Find({0, 0, 0})->Heaviest().label, 4u);
  ASSERT_TRUE(map.Deintegrate({0, 0, 0}, MultiLabelVoxel(4, 2)).ok());
  EXPECT_TRUE(map.empty());
}

TEST(SkiMapTest, CompactKeepsContentAndQueries) {
  SkiMap<MultiLabelVoxel> map({.resolution = 0.05});
  std::mt19937 rng(21);
  std::uniform_int_distribution<int> c(-30, 30);
  // Many small writes and removals scatter the nodes.
  for (int i = 0; i < 20000; ++i) {
    const VoxelKey k{c(rng), c(rng), c(rng) / 4};
    if (rng() % 4 == 0) {
      map.DeintegrateKey(k, MultiLabelVoxel(k.x & 3));
    } else {
      map.IntegrateKey(k, MultiLabelVoxel(k.x & 3));
    }
  }
  std::vector<std::pair<VoxelKey, MultiLabelVoxel>> before, after;
  map.ForEach([&](const VoxelKey& k, const MultiLabelVoxel& v) { before.emplace_back(k, v); });
  const size_t bytes_before = map.MemoryUsage();
  map.Compact();
  map.ForEach([&](const VoxelKey& k, const MultiLabelVoxel& v) { after.emplace_back(k, v); });
  EXPECT_EQ(before, after);
  EXPECT_EQ(map.size(), before.size());
  EXPECT_LE(map.MemoryUsage(), bytes_before);  // measured 795 664 -> 777 480 B (2026-11-23)
  size_t hits = 0;
  map.RadiusSearch({0, 0, 0}, 0.5, [&](const VoxelKey&, const MultiLabelVoxel&) { ++hits; });
  EXPECT_GE(hits, 590u);  // measured 887 (2026-11-23, seeded); two thirds
  // The map stays writable: everything can still be removed.
  for (auto& [k, v] : after) map.DeintegrateKey(k, v);
  EXPECT_TRUE(map.empty());
}

TEST(SkiMapTest, ClearRemovesEverything) {
  SkiMap<WeightVoxel> map({.resolution = 0.1});
  const size_t empty_bytes = map.MemoryUsage();
  for (int i = 0; i < 100; ++i) map.IntegrateKey({i, -i, i % 3}, {1});
  map.Clear();
  EXPECT_TRUE(map.empty());
  EXPECT_EQ(map.MemoryUsage(), empty_bytes);
  int visited = 0;
  map.ForEach([&](const VoxelKey&, const WeightVoxel&) { ++visited; });
  EXPECT_EQ(visited, 0);
}

}  // namespace
}  // namespace skimap
