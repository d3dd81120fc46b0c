// The random forest on synthetic many-class data: accuracy, confidences, determinism,
// serialization and corruption handling, option validation.
#include "perception/objects/random_forest.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <random>

namespace skimap::objects {
namespace {

// `classes` prototypes in {0,1}^dims; samples flip each bit with probability p.
TrainingSet BitPrototypes(int classes, int per_class, int dims, double p, uint32_t seed,
                          std::vector<std::vector<float>>* protos) {
  std::mt19937 rng(seed);
  if (protos->empty()) {
    std::bernoulli_distribution coin(0.5);
    protos->assign(classes, std::vector<float>(dims));
    for (auto& proto : *protos) {
      for (float& x : proto) x = coin(rng) ? 1.f : 0.f;
    }
  }
  std::bernoulli_distribution flip(p);
  TrainingSet set{.dims = dims};
  std::vector<float> x(dims);
  for (int i = 0; i < per_class; ++i) {
    for (int c = 0; c < classes; ++c) {
      for (int d = 0; d < dims; ++d) x[d] = flip(rng) ? 1.f - (*protos)[c][d] : (*protos)[c][d];
      set.Add(x, static_cast<uint32_t>(c));
    }
  }
  return set;
}

TEST(RandomForestTest, ClassifiesManyClassesAboveNinetyPercent) {
  std::vector<std::vector<float>> protos;
  const TrainingSet train = BitPrototypes(300, 20, 128, 0.08, 1, &protos);
  const TrainingSet test = BitPrototypes(300, 5, 128, 0.08, 2, &protos);
  absl::StatusOr<RandomForest> f =
      RandomForest::Train(train, 300, {.trees = 24, .max_depth = 24, .seed = 5});
  ASSERT_TRUE(f.ok()) << f.status();
  int correct = 0;
  std::vector<ClassScore> out;
  for (size_t i = 0; i < test.size(); ++i) {
    f->Predict(&test.features[i * test.dims], 3, &out);
    ASSERT_FALSE(out.empty());
    ASSERT_LE(out.size(), 3u);
    for (size_t k = 1; k < out.size(); ++k) EXPECT_GE(out[k - 1].confidence, out[k].confidence);
    EXPECT_LE(out[0].confidence, 1.0f + 1e-6f);
    correct += out[0].cls == test.labels[i];
  }
  std::printf("[ measured ] forest accuracy %.3f on %zu samples\n", double(correct) / test.size(),
              test.size());
  // Measured 2026-11-23: 0.998 (3 errors in 1500; deterministic for the seeds). Two thirds
  // of that (or of the margin over chance, 1/300) would be 0.67, which a forest with
  // broken splits can still reach; the floor allows ten times the measured error rate.
  EXPECT_GE(correct, 0.98 * test.size());
}

TEST(RandomForestTest, PredictManyGivesEveryRowsPredict) {
  std::vector<std::vector<float>> protos;
  const TrainingSet train = BitPrototypes(50, 10, 64, 0.1, 3, &protos);
  const TrainingSet test = BitPrototypes(50, 3, 64, 0.1, 4, &protos);
  absl::StatusOr<RandomForest> f =
      RandomForest::Train(train, 50, {.trees = 8, .max_depth = 16, .seed = 2});
  ASSERT_TRUE(f.ok()) << f.status();
  std::vector<std::vector<ClassScore>> many;
  f->PredictMany(test.features.data(), test.size(), 3, &many);
  ASSERT_EQ(many.size(), test.size());
  std::vector<ClassScore> one;
  for (size_t i = 0; i < test.size(); ++i) {
    f->Predict(&test.features[i * test.dims], 3, &one);
    ASSERT_EQ(many[i].size(), one.size()) << "row " << i;
    for (size_t k = 0; k < one.size(); ++k) {
      EXPECT_EQ(many[i][k].cls, one[k].cls) << "row " << i;
      EXPECT_EQ(many[i][k].confidence, one[k].confidence) << "row " << i;
    }
  }
  // The same on packed bits (the features are 0/1).
  std::vector<uint8_t> packed(test.size() * 8, 0);
  for (size_t i = 0; i < test.size(); ++i) {
    for (int d = 0; d < 64; ++d) {
      if (test.features[i * 64 + d] > 0.5f) packed[i * 8 + d / 8] |= uint8_t(1 << (d % 8));
    }
  }
  std::vector<std::vector<ClassScore>> bits;
  f->PredictManyBits(packed.data(), 8, test.size(), 3, &bits);
  ASSERT_EQ(bits.size(), many.size());
  for (size_t i = 0; i < many.size(); ++i) {
    ASSERT_EQ(bits[i].size(), many[i].size());
    for (size_t k = 0; k < many[i].size(); ++k) EXPECT_EQ(bits[i][k].cls, many[i][k].cls);
  }
  f->PredictMany(test.features.data(), 0, 3, &many);
  EXPECT_TRUE(many.empty());
}

TEST(RandomForestTest, SameSeedSameForestAndSerializationRoundTrips) {
  std::vector<std::vector<float>> protos;
  const TrainingSet train = BitPrototypes(50, 10, 64, 0.1, 3, &protos);
  absl::StatusOr<RandomForest> a = RandomForest::Train(train, 50, {.trees = 4, .threads = 2});
  absl::StatusOr<RandomForest> b = RandomForest::Train(train, 50, {.trees = 4, .threads = 1});
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(*a, *b);  // independent of the thread count
  const std::string blob = a->Serialize();
  absl::StatusOr<RandomForest> back = RandomForest::Deserialize(blob);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(*back, *a);

  std::string corrupt = blob;
  corrupt[corrupt.size() / 2] ^= 0x10;
  EXPECT_EQ(RandomForest::Deserialize(corrupt).status().code(), absl::StatusCode::kDataLoss);
  EXPECT_EQ(RandomForest::Deserialize(blob.substr(0, 20)).status().code(),
            absl::StatusCode::kDataLoss);
  EXPECT_EQ(RandomForest::Deserialize("nope, not a forest").status().code(),
            absl::StatusCode::kInvalidArgument);
}

TEST(RandomForestTest, BadInputsNameTheField) {
  TrainingSet set{.dims = 2};
  const float x[2] = {0, 1};
  set.Add(x, 0);
  auto msg = [&](const ForestOptions& o, uint32_t classes = 1) {
    return std::string(RandomForest::Train(set, classes, o).status().message());
  };
  EXPECT_NE(msg({.trees = 0}).find("trees"), std::string::npos);
  EXPECT_NE(msg({.max_depth = 0}).find("max_depth"), std::string::npos);
  EXPECT_NE(msg({.leaf_classes = 0}).find("leaf_classes"), std::string::npos);
  EXPECT_NE(msg({.bootstrap_fraction = 0}).find("bootstrap_fraction"), std::string::npos);
  EXPECT_NE(msg({}, 0).find("num_classes"), std::string::npos);
  set.labels[0] = 7;
  EXPECT_NE(msg({}, 2).find("label"), std::string::npos);
  EXPECT_EQ(RandomForest::Train(TrainingSet{.dims = 2}, 1, {}).status().code(),
            absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace skimap::objects
