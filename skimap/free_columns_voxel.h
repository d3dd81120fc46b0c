// FreeColumnsVoxel: the free-space evidence of a 4 × 4 block of (x, y) columns in one voxel.
//
//   key:    (x & ~3, y & ~3, 0), the block's lowest column (BlockKey)
//   counts: per column (Index(x, y)), the frames whose rays crossed that column's band
//
// A carving map's free volume holds one of these per block instead of one WeightVoxel per
// column: a robot frame's fan of ~80 000 columns at 1 cm becomes ~5 000 tree updates of 16
// counts each (bench/free_space_bench.cc). Counts are integers, so integrating then
// de-integrating the same evidence restores a block exactly; subtracting more than present
// clamps at zero. A block is empty when every count is zero.
//
// Volumes written before blocks held one WeightVoxel per column (key z 0); FromLegacy folds
// one of those into its block, so old snapshots and exports still load.
//
// Thread safety: a value type.
#ifndef SKIMAP_FREE_COLUMNS_VOXEL_H_
#define SKIMAP_FREE_COLUMNS_VOXEL_H_

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>

#include "base/encoding.h"
#include "skimap/voxel.h"

namespace skimap {

struct FreeColumnsVoxel {
  static constexpr uint32_t kTypeId = 6;
  static constexpr int32_t kSide = 4;  // columns per block edge
  static constexpr int kColumns = kSide * kSide;
  using Legacy = WeightVoxel;

  std::array<uint32_t, kColumns> counts{};

  // The block of column (x, y), and the column's slot in it (x major).
  static VoxelKey BlockKey(int32_t x, int32_t y) { return {x & ~(kSide - 1), y & ~(kSide - 1), 0}; }
  static int Index(int32_t x, int32_t y) { return (x & (kSide - 1)) * kSide + (y & (kSide - 1)); }

  FreeColumnsVoxel& operator+=(const FreeColumnsVoxel& o) {
    for (int i = 0; i < kColumns; ++i) counts[i] += o.counts[i];
    return *this;
  }
  FreeColumnsVoxel& operator-=(const FreeColumnsVoxel& o) {
    for (int i = 0; i < kColumns; ++i) counts[i] -= std::min(counts[i], o.counts[i]);
    return *this;
  }
  bool IsEmpty() const {
    return std::all_of(counts.begin(), counts.end(), [](uint32_t c) { return c == 0; });
  }
  // The largest count of the block.
  float Weight() const { return float(*std::max_element(counts.begin(), counts.end())); }
  // Columns with a count > 0.
  int Columns() const {
    return int(std::count_if(counts.begin(), counts.end(), [](uint32_t c) { return c > 0; }));
  }
  size_t HeapBytes() const { return 0; }

  // A 16-bit mask of the columns with counts (low byte first), then their counts in slot
  // order.
  void Encode(Encoder& e) const {
    uint32_t mask = 0;
    for (int i = 0; i < kColumns; ++i) mask |= uint32_t(counts[i] > 0) << i;
    e.U8(uint8_t(mask));
    e.U8(uint8_t(mask >> 8));
    for (int i = 0; i < kColumns; ++i) {
      if (counts[i] > 0) e.U32(counts[i]);
    }
  }
  // Rejects a zero count listed in the mask (it would be stored but not there).
  static bool Decode(Decoder& d, FreeColumnsVoxel* v) {
    uint8_t lo = 0, hi = 0;
    if (!d.U8(&lo) || !d.U8(&hi)) return false;
    const uint32_t mask = uint32_t(lo) | uint32_t(hi) << 8;
    *v = {};
    for (int i = 0; i < kColumns; ++i) {
      if (!(mask >> i & 1)) continue;
      if (!d.U32(&v->counts[i]) || v->counts[i] == 0) return false;
    }
    return true;
  }

  // One column's WeightVoxel of the old free volume as its block's voxel. False for what
  // that volume never held (z key not 0, a weight that is not a whole positive count).
  static bool FromLegacy(const VoxelKey& key, const WeightVoxel& legacy, VoxelKey* block,
                         FreeColumnsVoxel* out) {
    const float w = legacy.weight;
    if (key.z != 0 || !(w >= 1 && w <= 4e9f) || std::nearbyint(w) != w) return false;
    *block = BlockKey(key.x, key.y);
    *out = {};
    out->counts[Index(key.x, key.y)] = uint32_t(w);
    return true;
  }

  friend bool operator==(const FreeColumnsVoxel&, const FreeColumnsVoxel&) = default;
};

}  // namespace skimap

#endif  // SKIMAP_FREE_COLUMNS_VOXEL_H_
