#include "skimap/serialization.h"

#include <gtest/gtest.h>

#include <random>

#include "skimap/hypotheses_voxel.h"
#include "skimap/label_voxel.h"

namespace skimap {
namespace {

template <class V>
std::vector<std::pair<VoxelKey, V>> Contents(const SkiMap<V>& map) {
  std::vector<std::pair<VoxelKey, V>> out;
  map.ForEach([&](const VoxelKey& k, const V& v) { out.emplace_back(k, v); });
  return out;
}

SkiMap<RGBWeightedVoxel>::Options RgbOptions() {
  return {.resolution = 0.02, .origin = {1.5, -2.25, 0.125}};
}

std::unique_ptr<SkiMap<RGBWeightedVoxel>> SmallRgbMap() {
  auto map = std::make_unique<SkiMap<RGBWeightedVoxel>>(RgbOptions());
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int i = 0; i < 300; ++i) {
    EXPECT_TRUE(map->Integrate({u(rng), u(rng), u(rng)},
                               RGBWeightedVoxel(rng() % 256, rng() % 256, rng() % 256, 1 + i % 3))
                    .ok());
  }
  return map;
}

TEST(SerializationTest, RgbMapRoundTrips) {
  auto map = SmallRgbMap();
  const std::string bytes = SerializeMap(*map);
  absl::StatusOr<std::unique_ptr<SkiMap<RGBWeightedVoxel>>> copy =
      DeserializeMap<RGBWeightedVoxel>(bytes, {});
  ASSERT_TRUE(copy.ok()) << copy.status();
  EXPECT_EQ((*copy)->grid().resolution(), 0.02);
  EXPECT_EQ((*copy)->grid().origin().y, -2.25);
  const auto a = Contents(*map), b = Contents(**copy);
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].first, b[i].first);
    EXPECT_EQ(a[i].second.r, b[i].second.r);
    EXPECT_EQ(a[i].second.weight, b[i].second.weight);
  }
  // Deterministic: the same map always gives the same bytes.
  EXPECT_EQ(SerializeMap(**copy), bytes);
}

TEST(SerializationTest, SemanticVoxelTypesRoundTrip) {
  SkiMap<MultiLabelVoxel> labels({.resolution = 0.01});
  ASSERT_TRUE(labels.Integrate({0, 0, 0}, MultiLabelVoxel(3, 2)).ok());
  ASSERT_TRUE(labels.Integrate({0, 0, 0}, MultiLabelVoxel(1, 5)).ok());
  ASSERT_TRUE(labels.Integrate({-1, 0, 0}, MultiLabelVoxel(8)).ok());
  auto labels_copy = DeserializeMap<MultiLabelVoxel>(SerializeMap(labels), {});
  ASSERT_TRUE(labels_copy.ok()) << labels_copy.status();
  EXPECT_EQ(Contents(labels), Contents(**labels_copy));

  SkiMap<HypothesesVoxel> hyps({.resolution = 0.03});
  ASSERT_TRUE(
      hyps.Integrate({0.1, 0.2, 0.3}, HypothesesVoxel({{0.1f, 0.2f, 0.3f}, {0, 0, 1, 0}, 7, 0.9f}))
          .ok());
  auto hyps_copy = DeserializeMap<HypothesesVoxel>(SerializeMap(hyps), {});
  ASSERT_TRUE(hyps_copy.ok());
  EXPECT_EQ(Contents(hyps), Contents(**hyps_copy));

  SkiMap<InstancesVoxel> inst({.resolution = 0.05});
  ASSERT_TRUE(inst.Integrate({1, 1, 1}, InstancesVoxel({.id = 42, .object_id = 2})).ok());
  auto inst_copy = DeserializeMap<InstancesVoxel>(SerializeMap(inst), {});
  ASSERT_TRUE(inst_copy.ok());
  EXPECT_EQ(Contents(inst), Contents(**inst_copy));
}

TEST(SerializationTest, EveryFlippedByteIsDetected) {
  auto map = SmallRgbMap();
  const std::string bytes = SerializeMap(*map);
  for (size_t i = 0; i < bytes.size(); i += 7) {
    std::string bad = bytes;
    bad[i] = static_cast<char>(bad[i] ^ 0x5A);
    EXPECT_FALSE(DeserializeMap<RGBWeightedVoxel>(bad, {}).ok()) << "flipped byte " << i;
  }
}

TEST(SerializationTest, EveryTruncationIsDetected) {
  SkiMap<MultiLabelVoxel> map({.resolution = 0.01});
  for (int i = 0; i < 20; ++i)
    ASSERT_TRUE(map.Integrate({i * 0.01, 0, 0}, MultiLabelVoxel(i)).ok());
  const std::string bytes = SerializeMap(map);
  for (size_t n = 0; n < bytes.size(); ++n) {
    absl::StatusOr<std::unique_ptr<SkiMap<MultiLabelVoxel>>> r =
        DeserializeMap<MultiLabelVoxel>(bytes.substr(0, n), {});
    EXPECT_FALSE(r.ok()) << "length " << n;
  }
}

// Re-seals a modified body with a valid checksum, to reach the checks behind the CRC.
std::string ResealBody(std::string bytes) {
  bytes.resize(bytes.size() - 4);
  const uint32_t crc = Crc32c(bytes);
  Encoder(&bytes).U32(crc);
  return bytes;
}

TEST(SerializationTest, WellFormedButWrongFilesAreRejectedWithReasons) {
  auto map = SmallRgbMap();
  const std::string bytes = SerializeMap(*map);
  auto wrong_type = DeserializeMap<MultiLabelVoxel>(bytes, {});
  EXPECT_EQ(wrong_type.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(wrong_type.status().message().find("voxel type"), std::string::npos);

  std::string v2 = bytes;
  v2[4] = 2;  // format version
  EXPECT_EQ(DeserializeMap<RGBWeightedVoxel>(ResealBody(v2), {}).status().code(),
            absl::StatusCode::kInvalidArgument);

  std::string huge_count = bytes;
  huge_count[kMapHeaderBytes - 1] = 0x7F;
  EXPECT_EQ(DeserializeMap<RGBWeightedVoxel>(ResealBody(huge_count), {}).status().code(),
            absl::StatusCode::kDataLoss);

  std::string not_a_map = "hello world, this is not a map file at all......";
  EXPECT_EQ(DeserializeMap<RGBWeightedVoxel>(not_a_map, {}).status().code(),
            absl::StatusCode::kInvalidArgument);
}

TEST(SerializationTest, OutOfOrderKeysAreRejected) {
  SkiMap<WeightVoxel> map({.resolution = 1});
  map.IntegrateKey({0, 0, 0}, {1});
  map.IntegrateKey({0, 0, 1}, {2});
  std::string bytes = SerializeMap(map);
  // Swap the two records (12 key bytes + 4 weight bytes each).
  const size_t a = kMapHeaderBytes, b = kMapHeaderBytes + 16;
  std::string first = bytes.substr(a, 16);
  bytes.replace(a, 16, bytes.substr(b, 16));
  bytes.replace(b, 16, first);
  auto r = DeserializeMap<WeightVoxel>(ResealBody(bytes), {});
  EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(r.status().message().find("out of order"), std::string::npos);
}

}  // namespace
}  // namespace skimap
