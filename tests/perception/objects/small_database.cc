#include "tests/perception/objects/small_database.h"

#include <gtest/gtest.h>

#include <random>

#include "absl/strings/str_cat.h"
#include "server/core/objects/object_database_io.h"
#include "skimap/serialization.h"
#include "skimap/skimap.h"
#include "skimap/voxel.h"

namespace skimap::objects {

RandomForest SmallOrbForest(int classes) {
  // Random bit prototypes per class; samples flip 5 % of the bits.
  std::mt19937 rng(17);
  std::bernoulli_distribution coin(0.5), flip(0.05);
  std::vector<std::vector<float>> protos(classes, std::vector<float>(kSmallDims));
  for (auto& p : protos) {
    for (float& x : p) x = coin(rng);
  }
  TrainingSet set{.dims = kSmallDims};
  std::vector<float> x(kSmallDims);
  for (int i = 0; i < 20; ++i) {
    for (int c = 0; c < classes; ++c) {
      for (int d = 0; d < kSmallDims; ++d) x[d] = flip(rng) ? 1 - protos[c][d] : protos[c][d];
      set.Add(x, static_cast<uint32_t>(c));
    }
  }
  absl::StatusOr<RandomForest> f =
      RandomForest::Train(set, classes, {.trees = 3, .max_depth = 8, .seed = 3});
  EXPECT_TRUE(f.ok()) << f.status();
  return f.ok() ? *std::move(f) : RandomForest();
}

ObjectDatabase SmallOrbDatabase(const std::vector<std::vector<VoxelKey>>& voxels_per_object,
                                bool with_surface, double surface_resolution) {
  const int per_object = static_cast<int>(voxels_per_object.at(0).size());
  ObjectDatabaseParams p;
  p.features.detector = "ORB";
  p.classes_per_object = per_object;
  p.forest.trees = 3;
  p.forest.max_depth = 8;
  absl::StatusOr<ObjectDatabaseParams> resolved = ResolveParams(p);
  EXPECT_TRUE(resolved.ok()) << resolved.status();
  std::mt19937 rng(5);
  std::vector<ObjectModel> objects;
  for (size_t o = 0; o < voxels_per_object.size(); ++o) {
    ObjectModel m{.obj_id = 10 + static_cast<int>(o), .name = absl::StrCat("object ", o)};
    for (size_t j = 0; j < voxels_per_object[o].size(); ++j) {
      VoxelModel v{.key = voxels_per_object[o][j], .evidence = static_cast<uint32_t>(10 - j)};
      v.centroids = DescriptorMatrix(*DetectorLayout("ORB"));
      uint8_t bits[kSmallDims / 8];
      for (uint8_t& b : bits) b = static_cast<uint8_t>(rng());
      v.centroids.AppendBits(bits);
      v.cardinalities = {v.evidence};
      m.voxels.push_back(std::move(v));
    }
    if (with_surface) {
      SkiMap<RGBWeightedVoxel> rgb(
          {.resolution = surface_resolution > 0 ? surface_resolution : resolved->resolution});
      for (const VoxelKey& k : voxels_per_object[o]) rgb.IntegrateKey(k, {128, 128, 128, 1});
      m.rgb_volume = SerializeMap(rgb);
    }
    objects.push_back(std::move(m));
  }
  absl::StatusOr<ObjectDatabase> db = ObjectDatabase::Create(
      *resolved, std::move(objects),
      SmallOrbForest(per_object * static_cast<int>(voxels_per_object.size())));
  EXPECT_TRUE(db.ok()) << db.status();
  return db.ok() ? *std::move(db) : ObjectDatabase();
}

}  // namespace skimap::objects
