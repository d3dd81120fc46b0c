// Radix sorting of 64-bit sort keys, the engine of VoxelBatch::Finalize.
//
// A sort key is (relative voxel key << index_bits) | item index: sorting on the key bits
// alone orders items by voxel and, being stable, keeps equal voxels in insertion order.
//
// Thread safety: pure functions on caller-owned buffers.
#ifndef SKIMAP_KEY_SORT_H_
#define SKIMAP_KEY_SORT_H_

#include <cstddef>
#include <cstdint>
#include <vector>

namespace skimap::internal {

// LSD radix sort of a[0..n) on bits [shift, shift + bits), using b[0..n) as scratch.
// Returns the buffer (a or b) that holds the sorted keys.
uint64_t* RadixSort(uint64_t* a, uint64_t* b, size_t n, int shift, int bits);

// Splits keys into `parts` contiguous ranges of the top `top_bits` of the key field
// [shift, shift + bits) with about equal counts, and scatters a[0..n) into b so that
// part p occupies b[offsets[p] .. offsets[p + 1]). Every key of part p sorts before every
// key of part p + 1. REQUIRES: top_bits <= 20, parts >= 1.
std::vector<size_t> PartitionByTopBits(const uint64_t* a, uint64_t* b, size_t n, int shift,
                                       int bits, int top_bits, size_t parts);

}  // namespace skimap::internal

#endif  // SKIMAP_KEY_SORT_H_
