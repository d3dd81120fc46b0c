// Descriptor matrices, distances, forest features, the DescriptorVoxel and the class stack.
#include <gtest/gtest.h>

#include <random>

#include "perception/objects/class_stack.h"
#include "perception/objects/descriptor_voxel.h"
#include "skimap/serialization.h"
#include "skimap/skimap.h"

namespace skimap::objects {
namespace {

TEST(DescriptorTest, HammingAndL2Distances) {
  const DescriptorLayout bin{DescriptorKind::kBinary, 256};
  std::vector<uint8_t> a(32, 0), b(32, 0);
  b[0] = 0xFF;
  b[31] = 0x01;
  EXPECT_EQ(DescriptorDistance(bin, {.bits = a.data()}, {.bits = b.data()}), 9.0f);
  const DescriptorLayout flt{DescriptorKind::kFloat, 2};
  const float x[2] = {0, 0}, y[2] = {3, 4};
  EXPECT_FLOAT_EQ(DescriptorDistance(flt, {.values = x}, {.values = y}), 5.0f);
}

TEST(DescriptorTest, BinaryFeaturesAreUnpackedBits) {
  const DescriptorLayout bin{DescriptorKind::kBinary, 16};
  const uint8_t bits[2] = {0b00000101, 0b10000000};
  std::vector<float> f(16);
  ToFeatures(bin, {.bits = bits}, f);
  for (int i = 0; i < 16; ++i) EXPECT_EQ(f[i], (i == 0 || i == 2 || i == 15) ? 1.0f : 0.0f);
}

TEST(DescriptorTest, EncodeDecodeRoundTripAndTruncation) {
  DescriptorMatrix m({DescriptorKind::kFloat, 3});
  const float r0[3] = {1.5f, -2, 3}, r1[3] = {0, 0.25f, 1e9f};
  m.AppendValues(r0);
  m.AppendValues(r1);
  std::string bytes;
  Encoder e(&bytes);
  m.Encode(e);
  DescriptorMatrix back;
  Decoder d(bytes);
  ASSERT_TRUE(DescriptorMatrix::Decode(d, &back));
  EXPECT_EQ(back, m);
  Decoder truncated(std::string_view(bytes).substr(0, bytes.size() - 1));
  EXPECT_FALSE(DescriptorMatrix::Decode(truncated, &back));
}

TEST(DescriptorVoxelTest, DeintegrationRestoresTheVoxel) {
  const DescriptorLayout bin{DescriptorKind::kBinary, 32};
  const uint8_t a[4] = {1, 2, 3, 4}, b[4] = {5, 6, 7, 8};
  DescriptorVoxel v = DescriptorVoxel::One(bin, {.bits = a});
  const DescriptorVoxel before = v;
  v += DescriptorVoxel::One(bin, {.bits = b});
  v += DescriptorVoxel::One(bin, {.bits = a});
  EXPECT_EQ(v.Weight(), 3.0f);
  v -= DescriptorVoxel::One(bin, {.bits = b});
  v -= DescriptorVoxel::One(bin, {.bits = a});
  EXPECT_EQ(v, before);
  v -= DescriptorVoxel::One(bin, {.bits = a});
  EXPECT_TRUE(v.IsEmpty());
}

TEST(DescriptorVoxelTest, LivesInASkiMapAndSerializes) {
  const DescriptorLayout flt{DescriptorKind::kFloat, 4};
  SkiMap<DescriptorVoxel> map({.resolution = 0.01});
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> u(0, 1);
  for (int i = 0; i < 100; ++i) {
    const float d[4] = {u(rng), u(rng), u(rng), u(rng)};
    ASSERT_TRUE(map.Integrate({u(rng) * 0.05, u(rng) * 0.05, u(rng) * 0.05},
                              DescriptorVoxel::One(flt, {.values = d}))
                    .ok());
  }
  float total = 0;
  map.ForEach([&](const VoxelKey&, const DescriptorVoxel& v) { total += v.Weight(); });
  EXPECT_EQ(total, 100.0f);
  const std::string bytes = SerializeMap(map);
  auto copy = DeserializeMap<DescriptorVoxel>(bytes, {});
  ASSERT_TRUE(copy.ok()) << copy.status();
  EXPECT_EQ((*copy)->size(), map.size());
  map.ForEach([&](const VoxelKey& k, const DescriptorVoxel& v) {
    std::optional<DescriptorVoxel> w = (*copy)->Find(k);
    ASSERT_TRUE(w.has_value());
    EXPECT_EQ(*w, v);
  });
}

TEST(ClassStackTest, ClassesMapToObjectAndRank) {
  absl::StatusOr<ClassStack> s = ClassStack::Create(4, {10, 2, 4});
  ASSERT_TRUE(s.ok());
  EXPECT_EQ(s->num_classes(), 12u);
  for (int o = 0; o < 3; ++o) {
    for (int j = 0; j < 4; ++j) {
      const uint32_t c = s->ClassOf(o, j);
      EXPECT_EQ(c, static_cast<uint32_t>(o * 4 + j));  // Eq. 3: c = o * k + j
      EXPECT_EQ(s->ObjectOf(c), o);
      EXPECT_EQ(s->VoxelOf(c).object_index, o);
      EXPECT_EQ(s->VoxelOf(c).rank, j);
    }
  }
  EXPECT_EQ(s->used(1), 2);
  EXPECT_TRUE(s->Valid(s->ClassOf(1, 1)));
  EXPECT_FALSE(s->Valid(s->ClassOf(1, 2)));  // object 1 has only 2 voxels
  EXPECT_FALSE(s->Valid(12));
  EXPECT_EQ(ClassStack::Create(0, {1}).status().code(), absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace skimap::objects
