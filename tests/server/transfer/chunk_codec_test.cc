// Snapshot chunk blobs (server/core/transfer/chunk_codec.h) and frame-index chunks
// (server/core/maps/frame_index.h): exact round trips, and every corruption is an error, never
// a crash or a silently different map.
#include "server/core/transfer/chunk_codec.h"

#include <gtest/gtest.h>

#include <map>
#include <random>
#include <utility>

#include "server/core/maps/frame_index.h"
#include "skimap/free_columns_voxel.h"

namespace skimap::server {
namespace {

std::vector<VoxelBatch<RGBWeightedVoxel>::Item> SomeVoxels(const ChunkCoord& c, int n) {
  std::mt19937 rng(7);
  std::vector<VoxelBatch<RGBWeightedVoxel>::Item> out;
  const KeyBox box = ChunkBox(c);
  for (int i = 0; i < n; ++i) {
    const VoxelKey k{box.min.x + i % 32, box.min.y + (i / 32) % 32, box.min.z + i / 1024};
    out.push_back({k, RGBWeightedVoxel(rng() % 256, rng() % 256, rng() % 256, 1 + rng() % 9)});
  }
  return out;
}

TEST(ChunkCodecTest, VoxelChunksRoundTripExactlyAndCompress) {
  const ChunkCoord c{-3, 7, -1};
  const auto voxels = SomeVoxels(c, 3000);
  const std::string blob = EncodeVoxelChunk<RGBWeightedVoxel>(c, voxels);
  EXPECT_LT(blob.size(), voxels.size() * 19);  // 3 key bytes + 16 data bytes raw
  VoxelBatch<RGBWeightedVoxel> batch;
  ASSERT_TRUE(DecodeVoxelChunk<RGBWeightedVoxel>(c, blob, &batch).ok());
  ASSERT_EQ(batch.size(), voxels.size());
  for (size_t i = 0; i < voxels.size(); ++i) {
    const auto& got = batch.items()[i];
    EXPECT_EQ(got.key, voxels[i].key);
    EXPECT_EQ(got.data.r, voxels[i].data.r);
    EXPECT_EQ(got.data.weight, voxels[i].data.weight);
  }
  // Another voxel type or content is refused.
  VoxelBatch<WeightVoxel> other;
  EXPECT_EQ(DecodeVoxelChunk<WeightVoxel>(c, blob, &other).code(), absl::StatusCode::kDataLoss);
}

// Snapshots written before the free volume held blocks hold one WeightVoxel per column:
// they load as the blocks of the same columns and counts.
TEST(ChunkCodecTest, OldPerColumnFreeChunksLoadAsBlocks) {
  const ChunkCoord c{-1, 2, 0};
  const KeyBox box = ChunkBox(c);
  std::vector<VoxelBatch<WeightVoxel>::Item> columns;
  std::map<std::pair<int32_t, int32_t>, uint32_t> expected;
  for (int32_t x = 0; x < 32; x += 3) {
    for (int32_t y = 0; y < 32; y += 5) {
      const uint32_t count = uint32_t(1 + (x + y) % 4);
      columns.push_back({{box.min.x + x, box.min.y + y, 0}, WeightVoxel{float(count)}});
      expected[{box.min.x + x, box.min.y + y}] = count;
    }
  }
  VoxelBatch<FreeColumnsVoxel> blocks;
  ASSERT_TRUE(
      DecodeVoxelChunk<FreeColumnsVoxel>(c, EncodeVoxelChunk<WeightVoxel>(c, columns), &blocks)
          .ok());
  blocks.Finalize();
  std::map<std::pair<int32_t, int32_t>, uint32_t> got;
  for (const auto& item : blocks.items()) {
    EXPECT_TRUE(box.Contains(item.key));
    EXPECT_EQ(item.key, FreeColumnsVoxel::BlockKey(item.key.x, item.key.y));
    for (int32_t dx = 0; dx < 4; ++dx) {
      for (int32_t dy = 0; dy < 4; ++dy) {
        const uint32_t n =
            item.data.counts[size_t(FreeColumnsVoxel::Index(item.key.x + dx, item.key.y + dy))];
        if (n > 0) got[{item.key.x + dx, item.key.y + dy}] = n;
      }
    }
  }
  EXPECT_EQ(got, expected);
  // A per-column chunk with another layer was never written: refused.
  columns.push_back({{box.min.x, box.min.y, 1}, WeightVoxel{1}});
  VoxelBatch<FreeColumnsVoxel> bad;
  EXPECT_EQ(
      DecodeVoxelChunk<FreeColumnsVoxel>(c, EncodeVoxelChunk<WeightVoxel>(c, columns), &bad).code(),
      absl::StatusCode::kDataLoss);
  // Blocks round trip, and no other type passes for them.
  VoxelBatch<FreeColumnsVoxel> again;
  const std::vector<VoxelBatch<FreeColumnsVoxel>::Item> items(blocks.items().begin(),
                                                              blocks.items().end());
  ASSERT_TRUE(
      DecodeVoxelChunk<FreeColumnsVoxel>(c, EncodeVoxelChunk<FreeColumnsVoxel>(c, items), &again)
          .ok());
  EXPECT_EQ(again.size(), blocks.size());
  VoxelBatch<FreeColumnsVoxel> rgb;
  EXPECT_EQ(DecodeVoxelChunk<FreeColumnsVoxel>(
                c, EncodeVoxelChunk<RGBWeightedVoxel>(c, SomeVoxels(c, 10)), &rgb)
                .code(),
            absl::StatusCode::kDataLoss);
}

TEST(ChunkCodecTest, EveryCorruptionIsAnErrorNeverACrash) {
  const ChunkCoord c{0, 0, 0};
  const std::string blob = EncodeVoxelChunk<RGBWeightedVoxel>(c, SomeVoxels(c, 500));
  for (size_t at = 0; at < blob.size(); ++at) {
    std::string bad = blob;
    bad[at] = static_cast<char>(bad[at] ^ 0x5a);
    VoxelBatch<RGBWeightedVoxel> batch;
    const absl::Status s = DecodeVoxelChunk<RGBWeightedVoxel>(c, bad, &batch);
    EXPECT_FALSE(s.ok()) << "byte " << at;
    // The version bytes give the "newer" message; anything else is data loss.
    if (at == 4 || at == 5) {
      EXPECT_TRUE(absl::IsFailedPrecondition(s) || absl::IsDataLoss(s)) << s;
    } else {
      EXPECT_TRUE(absl::IsDataLoss(s)) << "byte " << at << ": " << s;
    }
  }
  for (size_t len = 0; len < blob.size(); len += 7) {
    VoxelBatch<RGBWeightedVoxel> batch;
    EXPECT_EQ(DecodeVoxelChunk<RGBWeightedVoxel>(c, blob.substr(0, len), &batch).code(),
              absl::StatusCode::kDataLoss)
        << "length " << len;
  }
}

TEST(ChunkCodecTest, AZstdChunkClaimingMoreThanItsPayloadCanHoldIsRefused) {
  const ChunkCoord c{0, 0, 0};
  std::string blob = EncodeVoxelChunk<RGBWeightedVoxel>(c, SomeVoxels(c, 500));
  ASSERT_EQ(blob[6], 1) << "expected a zstd chunk";
  // raw_size (bytes 16-19, little endian) claims 200 MiB; the checksum is made to match, as
  // a corrupt or hostile file would.
  const uint32_t claim = 200u << 20;
  for (int i = 0; i < 4; ++i) blob[16 + i] = static_cast<char>(claim >> (8 * i));
  std::string body = blob.substr(0, blob.size() - 4);
  const uint32_t crc = Crc32c(body);
  for (int i = 0; i < 4; ++i) body.push_back(static_cast<char>(crc >> (8 * i)));
  VoxelBatch<RGBWeightedVoxel> batch;
  const absl::Status s = DecodeVoxelChunk<RGBWeightedVoxel>(c, body, &batch);
  EXPECT_EQ(s.code(), absl::StatusCode::kDataLoss) << s;
  EXPECT_NE(s.message().find("zstd payload does not match its raw size"), std::string::npos) << s;
}

TEST(ChunkCodecTest, AChunkRepeatingAKeyIsRefused) {
  // Found by fuzzing: two huge weights at one key decoded, then merged into an infinite one.
  const ChunkCoord c{1, 0, 0};
  auto voxels = SomeVoxels(c, 40);
  voxels.push_back(voxels[7]);
  VoxelBatch<RGBWeightedVoxel> batch;
  const absl::Status s =
      DecodeVoxelChunk<RGBWeightedVoxel>(c, EncodeVoxelChunk<RGBWeightedVoxel>(c, voxels), &batch);
  EXPECT_EQ(s.code(), absl::StatusCode::kDataLoss) << s;
  EXPECT_NE(s.message().find("voxel 40 repeats a key"), std::string::npos) << s;
}

TEST(ChunkCodecTest, ANewerFormatVersionIsRefusedByName) {
  std::string blob = EncodeVoxelChunk<RGBWeightedVoxel>({0, 0, 0}, SomeVoxels({0, 0, 0}, 10));
  blob[4] = 2;  // version 2, little endian
  VoxelBatch<RGBWeightedVoxel> batch;
  const absl::Status s = DecodeVoxelChunk<RGBWeightedVoxel>({0, 0, 0}, blob, &batch);
  EXPECT_EQ(s.code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_NE(s.message().find("format version 2 is newer than this server's (1)"), std::string::npos)
      << s;
}

TEST(FrameIndexTest, BucketsRoundTripAndRetentionCutsOldestFirst) {
  FrameIndex index;
  perception::CameraPose pose;
  pose.rotation = Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()));
  pose.translation = {1.5, -2.25, 0.125};
  for (uint64_t seq : {3u, 4u, 5000u}) {
    index.Add(seq, {.position = seq + 10, .record_bytes = 100, .pose = pose});
  }
  std::vector<int64_t> dirty = index.TakeDirty();
  std::sort(dirty.begin(), dirty.end());
  ASSERT_EQ(dirty, (std::vector<int64_t>{0, 1}));
  FrameIndex copy;
  for (int64_t b : dirty) ASSERT_TRUE(copy.DecodeBucket(b, index.EncodeBucket(b)).ok());
  ASSERT_EQ(copy.size(), 3u);
  EXPECT_EQ(copy.Find(5000)->position, 5010u);
  EXPECT_TRUE(copy.Find(4)->pose.rotation.isApprox(pose.rotation, 0));
  EXPECT_EQ(copy.Find(4)->pose.translation, pose.translation);
  // A bucket decoded under another number is corrupt.
  FrameIndex wrong;
  EXPECT_EQ(wrong.DecodeBucket(7, index.EncodeBucket(0)).code(), absl::StatusCode::kDataLoss);
  // Retention: 300 bytes kept, budget 150 -> prune the two oldest records, never beyond
  // what the snapshot covers.
  EXPECT_EQ(index.RetentionCut(/*covered=*/5010, /*budget=*/150), 14u);
  EXPECT_EQ(index.RetentionCut(/*covered=*/13, /*budget=*/0), 13u);
  index.MarkPruned(14);
  EXPECT_EQ(index.journal_bytes(), 100u);
  EXPECT_TRUE(index.Pruned(*index.Find(4)));
  EXPECT_FALSE(index.Pruned(*index.Find(5000)));
}

}  // namespace
}  // namespace skimap::server
