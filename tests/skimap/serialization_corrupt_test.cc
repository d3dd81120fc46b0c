// Map files whose checksum is valid but whose structure is not (docs/formats.md, "SkiMap
// volume file"): each test edits one field of a well-formed file, re-seals the CRC-32C so
// the checksum passes, and expects the reader's documented error — never a crash, a huge
// allocation or a silently different map. Run under ASan+UBSan too (scripts/build.sh asan).
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>

#include "skimap/hypotheses_voxel.h"
#include "skimap/label_voxel.h"
#include "skimap/serialization.h"

namespace skimap {
namespace {

constexpr size_t kCountAt = kMapHeaderBytes - 8;  // u64 voxel count
constexpr size_t kResolutionAt = 12;              // f64
constexpr size_t kOriginAt = 20;                  // 3 x f64
constexpr size_t kFirstRecord = kMapHeaderBytes;  // key x, y, z (i32 each), then payload
constexpr size_t kKeyBytes = 12;

void PutU32(std::string& b, size_t at, uint32_t v) {
  for (int i = 0; i < 4; ++i) b[at + i] = static_cast<char>(v >> (8 * i));
}
void PutU64(std::string& b, size_t at, uint64_t v) {
  for (int i = 0; i < 8; ++i) b[at + i] = static_cast<char>(v >> (8 * i));
}
void PutF32(std::string& b, size_t at, float v) {
  uint32_t u;
  std::memcpy(&u, &v, 4);
  PutU32(b, at, u);
}
void PutF64(std::string& b, size_t at, double v) {
  uint64_t u;
  std::memcpy(&u, &v, 8);
  PutU64(b, at, u);
}

// Replaces the trailing CRC-32C with the checksum of the (edited) body.
std::string Reseal(std::string bytes) {
  bytes.resize(bytes.size() - 4);
  const uint32_t crc = Crc32c(bytes);
  Encoder(&bytes).U32(crc);
  return bytes;
}

template <class V>
absl::Status Load(const std::string& edited) {
  return DeserializeMap<V>(Reseal(edited), {}).status();
}

// Two weight voxels, 16-byte records: (0,0,0) weight 1 and (0,0,1) weight 2.
std::string TwoWeightVoxels() {
  SkiMap<WeightVoxel> map({.resolution = 0.05});
  map.IntegrateKey({0, 0, 0}, {1});
  map.IntegrateKey({0, 0, 1}, {2});
  return SerializeMap(map);
}

TEST(SerializationCorruptTest, UntouchedFilesStillLoad) {
  // The baseline every edit below departs from (and Reseal alone changes nothing).
  const std::string bytes = TwoWeightVoxels();
  EXPECT_EQ(Reseal(bytes), bytes);
  auto map = DeserializeMap<WeightVoxel>(bytes, {});
  ASSERT_TRUE(map.ok()) << map.status();
  EXPECT_EQ((*map)->size(), 2u);
}

TEST(SerializationCorruptTest, VoxelCountBeyondTheBytesIsDataLossWithoutAllocating) {
  const std::string bytes = TwoWeightVoxels();
  for (uint64_t count : {uint64_t{1} << 40, ~uint64_t{0}, uint64_t{3}}) {
    std::string bad = bytes;
    PutU64(bad, kCountAt, count);
    EXPECT_EQ(Load<WeightVoxel>(bad).code(), absl::StatusCode::kDataLoss) << count;
  }
  // A count smaller than the records leaves trailing bytes.
  std::string short_count = bytes;
  PutU64(short_count, kCountAt, 1);
  absl::Status s = Load<WeightVoxel>(short_count);
  EXPECT_EQ(s.code(), absl::StatusCode::kDataLoss);
  EXPECT_NE(s.message().find("trailing"), std::string::npos) << s;
}

TEST(SerializationCorruptTest, BadResolutionOrOriginIsInvalidArgument) {
  const std::string bytes = TwoWeightVoxels();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  for (double r : {0.0, -0.05, nan, inf}) {
    std::string bad = bytes;
    PutF64(bad, kResolutionAt, r);
    EXPECT_EQ(Load<WeightVoxel>(bad).code(), absl::StatusCode::kInvalidArgument) << r;
  }
  for (int axis = 0; axis < 3; ++axis) {
    for (double o : {nan, -inf}) {
      std::string bad = bytes;
      PutF64(bad, kOriginAt + 8 * axis, o);
      EXPECT_EQ(Load<WeightVoxel>(bad).code(), absl::StatusCode::kInvalidArgument)
          << "axis " << axis << " origin " << o;
    }
  }
}

TEST(SerializationCorruptTest, KeysOutOfRangeAreInvalidArgument) {
  const std::string bytes = TwoWeightVoxels();
  // Keys are limited to [-2^20, 2^20 - 1] on every axis.
  for (size_t axis = 0; axis < 3; ++axis) {
    for (int32_t k : {1 << 20, -(1 << 20) - 1, std::numeric_limits<int32_t>::min()}) {
      std::string bad = bytes;
      PutU32(bad, kFirstRecord + 4 * axis, static_cast<uint32_t>(k));
      absl::Status s = Load<WeightVoxel>(bad);
      EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << "axis " << axis << " key " << k;
      EXPECT_NE(s.message().find("out of range"), std::string::npos) << s;
    }
  }
}

TEST(SerializationCorruptTest, DuplicateKeysAreRejectedAsOutOfOrder) {
  std::string bad = TwoWeightVoxels();
  PutU32(bad, kFirstRecord + 16 + 8, 0);  // second key (0,0,1) -> (0,0,0)
  absl::Status s = Load<WeightVoxel>(bad);
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("out of order"), std::string::npos) << s;
}

TEST(SerializationCorruptTest, EmptyOrNonFiniteWeightsAreRejected) {
  const std::string bytes = TwoWeightVoxels();
  for (float w : {0.0f, -1.0f}) {
    std::string bad = bytes;
    PutF32(bad, kFirstRecord + kKeyBytes, w);
    absl::Status s = Load<WeightVoxel>(bad);
    EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << w;
    EXPECT_NE(s.message().find("empty"), std::string::npos) << s;
  }
  // A NaN or infinite weight would pass every "weight > threshold" test or none; the
  // record is malformed.
  for (float w :
       {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity()}) {
    std::string bad = bytes;
    PutF32(bad, kFirstRecord + kKeyBytes, w);
    EXPECT_EQ(Load<WeightVoxel>(bad).code(), absl::StatusCode::kDataLoss) << w;
  }
  // The same for a colour channel of an RGB voxel.
  SkiMap<RGBWeightedVoxel> rgb({.resolution = 0.05});
  rgb.IntegrateKey({1, 2, 3}, RGBWeightedVoxel(10, 20, 30, 1));
  std::string bad = SerializeMap(rgb);
  PutF32(bad, kFirstRecord + kKeyBytes + 4, std::numeric_limits<float>::quiet_NaN());  // g
  EXPECT_EQ(Load<RGBWeightedVoxel>(bad).code(), absl::StatusCode::kDataLoss);
}

// One label voxel {label 1: 5, label 3: 2}: n at +12, entries (label, count) from +16.
std::string OneLabelVoxel() {
  SkiMap<MultiLabelVoxel> map({.resolution = 0.01});
  MultiLabelVoxel v(1, 5);
  v += MultiLabelVoxel(3, 2);
  map.IntegrateKey({0, 0, 0}, v);
  return SerializeMap(map);
}

TEST(SerializationCorruptTest, LabelVoxelsWithBadEntriesAreRejected) {
  const std::string bytes = OneLabelVoxel();
  const size_t n_at = kFirstRecord + kKeyBytes, first = n_at + 4, second = n_at + 12;
  ASSERT_TRUE(DeserializeMap<MultiLabelVoxel>(bytes, {}).ok());
  {
    std::string bad = bytes;  // an entry count no record can hold
    PutU32(bad, n_at, 0xFFFFFFFFu);
    EXPECT_EQ(Load<MultiLabelVoxel>(bad).code(), absl::StatusCode::kDataLoss);
  }
  {
    std::string bad = bytes;  // labels descending (3, then 1)
    PutU32(bad, first, 3);
    PutU32(bad, second, 1);
    EXPECT_EQ(Load<MultiLabelVoxel>(bad).code(), absl::StatusCode::kDataLoss);
  }
  {
    std::string bad = bytes;  // the same label twice
    PutU32(bad, second, 1);
    EXPECT_EQ(Load<MultiLabelVoxel>(bad).code(), absl::StatusCode::kDataLoss);
  }
  {
    std::string bad = bytes;  // a label counted zero times
    PutU32(bad, second + 4, 0);
    EXPECT_EQ(Load<MultiLabelVoxel>(bad).code(), absl::StatusCode::kDataLoss);
  }
  {
    std::string bad = bytes;  // no entries: an empty voxel (its old entries become trailing)
    PutU32(bad, n_at, 0);
    absl::Status s = Load<MultiLabelVoxel>(bad);
    EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
    EXPECT_NE(s.message().find("empty"), std::string::npos) << s;
  }
}

TEST(SerializationCorruptTest, HypothesesAndInstancesWithBadCountsOrIdsAreRejected) {
  SkiMap<HypothesesVoxel> hyps({.resolution = 0.05});
  hyps.IntegrateKey({0, 0, 0}, HypothesesVoxel({{0.1f, 0.2f, 0.3f}, {1, 0, 0, 0}, 7, 0.9f}));
  std::string bad = SerializeMap(hyps);
  PutU32(bad, kFirstRecord + kKeyBytes, 1u << 30);
  EXPECT_EQ(Load<HypothesesVoxel>(bad).code(), absl::StatusCode::kDataLoss);

  // Two instances with ids 1 and 2; each is 104 bytes after the voxel's n.
  InstancesVoxel two({.id = 1, .object_id = 4});
  two += InstancesVoxel({.id = 2, .object_id = 5});
  SkiMap<InstancesVoxel> inst({.resolution = 0.05});
  inst.IntegrateKey({0, 0, 0}, two);
  const std::string bytes = SerializeMap(inst);
  ASSERT_TRUE(DeserializeMap<InstancesVoxel>(bytes, {}).ok());
  const size_t n_at = kFirstRecord + kKeyBytes, second_id = n_at + 4 + 104;
  bad = bytes;
  PutU64(bad, second_id, 1);  // ids must be unique
  EXPECT_EQ(Load<InstancesVoxel>(bad).code(), absl::StatusCode::kDataLoss);
  bad = bytes;
  PutU32(bad, n_at, 0xFFFFFFFFu);
  EXPECT_EQ(Load<InstancesVoxel>(bad).code(), absl::StatusCode::kDataLoss);
  bad = bytes;
  PutU32(bad, n_at, 2);  // the layout without view counts: the records are 8 bytes too long
  EXPECT_EQ(Load<InstancesVoxel>(bad).code(), absl::StatusCode::kDataLoss);
}

// Instances written before the view counts existed (bit 31 of n clear, 96-byte records)
// still load, with no view evidence.
TEST(SerializationCorruptTest, InstancesWithoutViewCountsLoad) {
  Instance a{
      .id = 1, .object_id = 4, .score = 120, .fit = 0.5f, .view_agree = 7, .view_conflict = 3};
  SkiMap<InstancesVoxel> inst({.resolution = 0.05});
  inst.IntegrateKey({0, 0, 0}, InstancesVoxel(a));
  std::string bytes = SerializeMap(inst);
  const size_t n_at = kFirstRecord + kKeyBytes, view_at = n_at + 4 + 96;
  PutU32(bytes, n_at, 1);
  bytes.erase(view_at, 8);
  absl::StatusOr<std::unique_ptr<SkiMap<InstancesVoxel>>> old =
      DeserializeMap<InstancesVoxel>(Reseal(bytes), {});
  ASSERT_TRUE(old.ok()) << old.status();
  std::optional<InstancesVoxel> v = (*old)->Find({0, 0, 0});
  ASSERT_TRUE(v.has_value());
  ASSERT_EQ(v->items().size(), 1u);
  Instance expected = a;
  expected.view_agree = expected.view_conflict = 0;
  EXPECT_EQ(v->items()[0], expected);
  EXPECT_EQ(ViewConflict(v->items()[0]), 0.0f);
  EXPECT_FLOAT_EQ(ViewConflict(a), 0.3f);
}

}  // namespace
}  // namespace skimap
