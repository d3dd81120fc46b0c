// Forest blobs and object database records whose checksum is valid but whose structure is
// not (docs/objects.md, "Random forest" and "SQLite schema"): each test edits one field of
// a well-formed model, re-seals the forest's CRC-32C so the checksum passes, and expects a
// clear error status — never a crash, a huge allocation or a silently different model.
// Run under ASan+UBSan too (scripts/build.sh asan objects_unit_test).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <limits>

#include "base/encoding.h"
#include "perception/objects/object_database.h"
#include "perception/objects/random_forest.h"
#include "server/core/objects/object_database_io.h"
#include "tests/perception/objects/small_database.h"

namespace skimap::objects {
namespace {

// The forest blob (random_forest_predict.cc): magic, version u32 @4, dims u32 @8,
// num_classes u32 @12, trees u32 @16, nodes u64 @20, leaves u64 @28, then trees x root u32,
// nodes x (feature i32, threshold f32, a u32, b u32), leaves x (class u32, fraction f32),
// CRC-32C.
constexpr size_t kVersionAt = 4, kDimsAt = 8, kClassesAt = 12, kTreesAt = 16, kNodesAt = 20,
                 kLeavesAt = 28, kRootsAt = 36;

uint32_t GetU32(const std::string& b, size_t at) {
  uint32_t v = 0;
  for (int i = 0; i < 4; ++i) v |= uint32_t{static_cast<uint8_t>(b[at + i])} << (8 * i);
  return v;
}
uint64_t GetU64(const std::string& b, size_t at) {
  return GetU32(b, at) | uint64_t{GetU32(b, at + 4)} << 32;
}
void PutU32(std::string& b, size_t at, uint32_t v) {
  for (int i = 0; i < 4; ++i) b[at + i] = static_cast<char>(v >> (8 * i));
}
void PutU64(std::string& b, size_t at, uint64_t v) {
  PutU32(b, at, static_cast<uint32_t>(v));
  PutU32(b, at + 4, static_cast<uint32_t>(v >> 32));
}
void PutF32(std::string& b, size_t at, float v) {
  uint32_t u;
  std::memcpy(&u, &v, 4);
  PutU32(b, at, u);
}

std::string Reseal(std::string bytes) {
  bytes.resize(bytes.size() - 4);
  const uint32_t crc = Crc32c(bytes);
  Encoder(&bytes).U32(crc);
  return bytes;
}

// Where the parts of a blob are, and its first split node and first leaf node.
struct BlobLayout {
  uint32_t trees = 0;
  uint64_t nodes = 0, leaves = 0;
  size_t nodes_at = 0, leaves_at = 0;
  size_t split = 0, leaf = 0;  // node indices
  size_t NodeAt(size_t i) const { return nodes_at + 16 * i; }
};

BlobLayout Parse(const std::string& blob) {
  BlobLayout l;
  l.trees = GetU32(blob, kTreesAt);
  l.nodes = GetU64(blob, kNodesAt);
  l.leaves = GetU64(blob, kLeavesAt);
  l.nodes_at = kRootsAt + 4 * size_t{l.trees};
  l.leaves_at = l.nodes_at + 16 * l.nodes;
  bool found_split = false, found_leaf = false;
  for (size_t i = 0; i < l.nodes; ++i) {
    const int32_t feature = static_cast<int32_t>(GetU32(blob, l.NodeAt(i)));
    if (feature >= 0 && !found_split) l.split = i, found_split = true;
    if (feature < 0 && !found_leaf) l.leaf = i, found_leaf = true;
  }
  EXPECT_TRUE(found_split && found_leaf);
  return l;
}

constexpr int kDims = kSmallDims;
constexpr int kObjects = 2, kVoxels = 3, kClasses = kObjects * kVoxels;

RandomForest SmallForest() { return SmallOrbForest(kClasses); }

const std::string& GoodBlob() {
  static const std::string* blob = new std::string(SmallForest().Serialize());
  return *blob;
}

absl::StatusCode LoadCode(const std::string& edited) {
  return RandomForest::Deserialize(Reseal(edited)).status().code();
}

TEST(ForestCorruptTest, TheUntouchedBlobLoads) {
  const std::string& blob = GoodBlob();
  EXPECT_EQ(Reseal(blob), blob);
  absl::StatusOr<RandomForest> f = RandomForest::Deserialize(blob);
  ASSERT_TRUE(f.ok()) << f.status();
  EXPECT_EQ(f->num_trees(), 3);
  const BlobLayout l = Parse(blob);
  EXPECT_GT(l.nodes, 3u);
}

TEST(ForestCorruptTest, CountsBeyondTheBytesAreDataLossWithoutAllocating) {
  const std::string& blob = GoodBlob();
  const BlobLayout l = Parse(blob);
  // Counts whose byte sizes wrap around 2^64 back to the real size, and plain huge ones.
  const std::vector<std::pair<size_t, uint64_t>> edits = {
      {kNodesAt, l.nodes + (uint64_t{1} << 60)},    // 16 x nodes wraps
      {kLeavesAt, l.leaves + (uint64_t{1} << 61)},  // 8 x leaves wraps
      {kNodesAt, uint64_t{1} << 40},
      {kLeavesAt, ~uint64_t{0}},
  };
  for (const auto& [at, value] : edits) {
    std::string bad = blob;
    PutU64(bad, at, value);
    EXPECT_EQ(LoadCode(bad), absl::StatusCode::kDataLoss) << "field @" << at << " = " << value;
  }
  std::string bad = blob;
  PutU32(bad, kTreesAt, 0xFFFFFFFFu);
  EXPECT_EQ(LoadCode(bad), absl::StatusCode::kDataLoss);
  // One section length off: the sizes no longer add up.
  bad = blob;
  PutU64(bad, kLeavesAt, l.leaves - 1);
  EXPECT_EQ(LoadCode(bad), absl::StatusCode::kDataLoss);
}

TEST(ForestCorruptTest, UnknownVersionIsInvalidArgument) {
  std::string bad = GoodBlob();
  PutU32(bad, kVersionAt, 2);
  EXPECT_EQ(LoadCode(bad), absl::StatusCode::kInvalidArgument);
}

TEST(ForestCorruptTest, RootsAndChildrenOutOfRangeOrBackwardsAreInvalidArgument) {
  const std::string& blob = GoodBlob();
  const BlobLayout l = Parse(blob);
  const uint32_t n = static_cast<uint32_t>(l.nodes);
  std::string bad = blob;
  PutU32(bad, kRootsAt + 4, n);  // second tree's root
  EXPECT_EQ(LoadCode(bad), absl::StatusCode::kInvalidArgument);
  const size_t split = l.NodeAt(l.split);
  const uint32_t self = static_cast<uint32_t>(l.split);
  for (size_t child : {split + 8, split + 12}) {  // a and b
    for (uint32_t target : {n, 0xFFFFFFFFu, self /* a cycle */}) {
      bad = blob;
      PutU32(bad, child, target);
      EXPECT_EQ(LoadCode(bad), absl::StatusCode::kInvalidArgument)
          << "child @" << child << " -> " << target;
    }
  }
}

TEST(ForestCorruptTest, FeaturesOutOfRangeAreInvalidArgument) {
  const std::string& blob = GoodBlob();
  const BlobLayout l = Parse(blob);
  for (int32_t feature : {kDims, std::numeric_limits<int32_t>::max(), -2}) {
    std::string bad = blob;
    PutU32(bad, l.NodeAt(l.split), static_cast<uint32_t>(feature));
    EXPECT_EQ(LoadCode(bad), absl::StatusCode::kInvalidArgument) << feature;
  }
  // The header's dims shrunk below the features the nodes use.
  std::string bad = blob;
  PutU32(bad, kDimsAt, 1);
  EXPECT_EQ(LoadCode(bad), absl::StatusCode::kInvalidArgument);
}

TEST(ForestCorruptTest, NonFiniteThresholdsAreInvalidArgument) {
  // A NaN threshold sends every sample the same way: a silently different model.
  const std::string& blob = GoodBlob();
  const BlobLayout l = Parse(blob);
  for (float t : {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity(),
                  -std::numeric_limits<float>::infinity()}) {
    std::string bad = blob;
    PutF32(bad, l.NodeAt(l.split) + 4, t);
    EXPECT_EQ(LoadCode(bad), absl::StatusCode::kInvalidArgument) << t;
  }
}

TEST(ForestCorruptTest, LeavesWithBadRangesClassesOrFractionsAreInvalidArgument) {
  const std::string& blob = GoodBlob();
  const BlobLayout l = Parse(blob);
  const size_t leaf = l.NodeAt(l.leaf);
  std::string bad = blob;
  PutU32(bad, leaf + 8, static_cast<uint32_t>(l.leaves));  // first entry past the pool
  EXPECT_EQ(LoadCode(bad), absl::StatusCode::kInvalidArgument);
  bad = blob;
  PutU32(bad, leaf + 12, 0xFFFFFFFFu);  // entry count wrapping the pool
  EXPECT_EQ(LoadCode(bad), absl::StatusCode::kInvalidArgument);

  // A class id beyond the class count, in an entry and via the header's count.
  bad = blob;
  PutU32(bad, l.leaves_at, kClasses);
  EXPECT_EQ(LoadCode(bad), absl::StatusCode::kInvalidArgument);
  bad = blob;
  PutU32(bad, kClassesAt, 0);
  EXPECT_EQ(LoadCode(bad), absl::StatusCode::kInvalidArgument);

  // Fractions are shares of a leaf's samples: in [0, 1].
  for (float f : {std::numeric_limits<float>::quiet_NaN(), -0.5f, 1.5f,
                  std::numeric_limits<float>::infinity()}) {
    bad = blob;
    PutF32(bad, l.leaves_at + 4, f);
    EXPECT_EQ(LoadCode(bad), absl::StatusCode::kInvalidArgument) << f;
  }
}

// A small but complete ORB object database: 2 objects x 3 voxels, k = 3, the forest above.
ObjectDatabase SmallDatabase() {
  std::vector<std::vector<VoxelKey>> voxels(kObjects);
  for (int o = 0; o < kObjects; ++o) {
    for (int j = 0; j < kVoxels; ++j) voxels[o].push_back({j, o, 0});
  }
  return SmallOrbDatabase(voxels);
}

TEST(ObjectDatabaseCorruptTest, RecordsRoundTripBeforeAnyEdit) {
  const ObjectDatabase db = SmallDatabase();
  absl::StatusOr<ObjectDatabase> back = FromStoredRecords(ToStoredRecords(db));
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_TRUE(*back == db);
}

TEST(ObjectDatabaseCorruptTest, AForestThatDoesNotFitTheObjectsIsRejected) {
  const storage::StoredObjectDatabase good = ToStoredRecords(SmallDatabase());
  // The forest claims one class more than the class stack has (resealed: CRC passes; the
  // forest row agrees with the blob).
  storage::StoredObjectDatabase r = good;
  PutU32(r.forest, kClassesAt, kClasses + 1);
  r.forest = Reseal(r.forest);
  r.forest_classes = kClasses + 1;
  EXPECT_EQ(FromStoredRecords(r).status().code(), absl::StatusCode::kInvalidArgument);
  // k changed under the forest: 2 objects x 2 classes, but the forest predicts 6.
  r = good;
  r.params["classes_per_object"] = "2";
  r.classes_per_object = 2;
  EXPECT_EQ(FromStoredRecords(r).status().code(), absl::StatusCode::kInvalidArgument);
  // The forest of another descriptor: 128 features for 256-bit ORB descriptors.
  r = good;
  PutU32(r.forest, kDimsAt, 128);
  std::string blob = r.forest;
  r.forest = Reseal(blob);
  EXPECT_FALSE(FromStoredRecords(r).ok());
  // A corrupt forest blob is the forest's error (the checksum catches it unresealed).
  r = good;
  r.forest[r.forest.size() / 2] ^= 0x20;
  EXPECT_EQ(FromStoredRecords(r).status().code(), absl::StatusCode::kDataLoss);
}

TEST(ObjectDatabaseCorruptTest, InconsistentRecordsAreRejected) {
  const storage::StoredObjectDatabase good = ToStoredRecords(SmallDatabase());
  storage::StoredObjectDatabase r = good;
  r.format_version = 2;
  EXPECT_EQ(FromStoredRecords(r).status().code(), absl::StatusCode::kInvalidArgument);
  r = good;
  r.descriptor_dims = 512;
  EXPECT_EQ(FromStoredRecords(r).status().code(), absl::StatusCode::kDataLoss);
  r = good;
  r.objects[1].obj_id = r.objects[0].obj_id;  // the same object twice
  EXPECT_EQ(FromStoredRecords(r).status().code(), absl::StatusCode::kInvalidArgument);
  r = good;
  r.objects[0].voxels[0].centroids[0].descriptor.pop_back();  // 31 of 32 bytes
  EXPECT_EQ(FromStoredRecords(r).status().code(), absl::StatusCode::kDataLoss);
  // Bad training parameters (the object_db columns edited alike, so that the parameters'
  // own validation answers).
  for (const auto& [key, value] :
       std::vector<std::pair<std::string, std::string>>{{"trees", "many"},
                                                        {"top_n", "100000"},
                                                        {"resolution", "5"},
                                                        {"classes_per_object", "-1"},
                                                        {"detector", "SURF"}}) {
    r = good;
    r.params[key] = value;
    if (key == "resolution") r.resolution = 5;
    if (key == "classes_per_object") r.classes_per_object = -1;
    if (key == "detector") r.detector = value;
    EXPECT_EQ(FromStoredRecords(r).status().code(), absl::StatusCode::kInvalidArgument)
        << key << " = " << value;
  }
  r = good;
  r.params.erase("verify_threshold");
  EXPECT_EQ(FromStoredRecords(r).status().code(), absl::StatusCode::kInvalidArgument);
}

TEST(ObjectDatabaseCorruptTest, ColumnsThatContradictTheParametersOrTheForestAreDataLoss) {
  // object_db and forest repeat what the training parameters and the forest blob say; a
  // row that disagrees is corrupt, whichever side is right.
  const storage::StoredObjectDatabase good = ToStoredRecords(SmallDatabase());
  const std::vector<std::pair<std::string, std::function<void(storage::StoredObjectDatabase&)>>>
      edits = {
          {"detector", [](auto& r) { r.detector = "BRISK"; }},
          {"resolution", [](auto& r) { r.resolution = 0.02; }},
          {"classes_per_object", [](auto& r) { r.classes_per_object = 2; }},
          {"forest trees", [](auto& r) { r.forest_trees = 4; }},
          {"forest classes", [](auto& r) { r.forest_classes = kClasses + 1; }},
      };
  for (const auto& [what, edit] : edits) {
    storage::StoredObjectDatabase r = good;
    edit(r);
    EXPECT_EQ(FromStoredRecords(r).status().code(), absl::StatusCode::kDataLoss) << what;
  }
}

TEST(ObjectDatabaseCorruptTest, ACorruptForestInSqliteFailsTheLoad) {
  // End to end through the SQLite file: the stored forest names a class beyond the count.
  const std::string path = ::testing::TempDir() + "/corrupt_forest.sqlite";
  std::remove(path.c_str());
  storage::StoredObjectDatabase r = ToStoredRecords(SmallDatabase());
  const BlobLayout l = Parse(r.forest);
  PutU32(r.forest, l.leaves_at, kClasses + 7);
  r.forest = Reseal(r.forest);
  {
    absl::StatusOr<std::unique_ptr<storage::ObjectStore>> store = storage::ObjectStore::Open(path);
    ASSERT_TRUE(store.ok()) << store.status();
    ASSERT_TRUE((*store)->Save(r).ok());
  }
  absl::StatusOr<ObjectDatabase> db = LoadObjectDatabase(path);
  EXPECT_EQ(db.status().code(), absl::StatusCode::kInvalidArgument) << db.status();
  std::remove(path.c_str());
}

}  // namespace
}  // namespace skimap::objects
