// Fuzz target: snapshot chunk blobs (server/core/transfer/chunk_codec.h) as a map load reads them:
// voxel chunks of every voxel type and frame-index chunks (server/core/maps/frame_index.h).
//
// Input: u8 control (low bits: 0-6 a voxel type (voxel_types.h), 7 the frame index;
// bit 7: recompute the trailing CRC first), then the blob. A voxel chunk that decodes must
// hold keys inside its chunk, and encode back to a blob that decodes to the same voxels.
#include <cstdint>
#include <string>
#include <vector>

#include "server/core/maps/frame_index.h"
#include "server/core/transfer/chunk_codec.h"
#include "tests/fuzz/fuzz_input.h"
#include "tests/fuzz/voxel_types.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace skimap;
  using namespace skimap::fuzz;
  FuzzInput in(data, size);
  const uint8_t control = in.U8();
  std::string blob(in.Rest());
  if (control & 0x80) FixTrailingCrc(&blob);
  const int which = (control & 0x7f) % (kVoxelTypes + 1);
  if (which == kVoxelTypes) {
    server::FrameIndex index;
    const absl::Status s = index.DecodeBucket(1, blob);
    if (!s.ok() && s.message().empty()) Fail("an error without a message");
    if (s.ok()) {
      const std::string again = index.EncodeBucket(1);
      server::FrameIndex copy;
      if (!copy.DecodeBucket(1, again).ok() || copy.size() != index.size()) {
        Fail("a frame-index chunk does not round trip");
      }
    }
    return 0;
  }
  VisitVoxelType(which, [&](auto voxel) {
    using V = decltype(voxel);
    const server::ChunkCoord c{-2, 3, 0};
    VoxelBatch<V> batch;
    const absl::Status s = server::DecodeVoxelChunk(c, blob, &batch);
    if (!s.ok()) {
      if (s.message().empty()) Fail("an error without a message");
      return;
    }
    batch.Finalize();
    const KeyBox box = server::ChunkBox(c);
    for (const auto& item : batch.items()) {
      if (!box.Contains(item.key)) Fail("a decoded voxel lies outside its chunk");
    }
    VoxelBatch<V> back;
    const std::vector<typename VoxelBatch<V>::Item> items(batch.items().begin(),
                                                          batch.items().end());
    if (!server::DecodeVoxelChunk(c, server::EncodeVoxelChunk<V>(c, items), &back).ok()) {
      Fail("a decoded chunk does not encode back");
    }
    back.Finalize();
    if (back.items().size() != batch.items().size()) Fail("chunk round trip lost voxels");
  });
  return 0;
}
