// NodePool: a small-object allocator for skip-list nodes.
//
// Memory is carved from chunks obtained with operator new (the first chunk is small, later
// ones a quarter of what the pool holds, up to kMaxChunkBytes: a pool of three nodes does
// not cost 64 KiB, and unused chunk tails stay under ~20%). Freed blocks go to a free list
// per size class and are reused by the next allocation of the same size; when the last
// block is freed the pool returns all its chunks to the system.
// Blocks larger than kMaxPooledBytes bypass the pool (plain operator new / delete).
//
// Thread safety: not thread safe; the owner serializes access (SkiMap gives each x column
// its own pool, used only under that column's writer lock).
#ifndef SKIMAP_NODE_POOL_H_
#define SKIMAP_NODE_POOL_H_

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

namespace skimap {

class NodePool {
 public:
  static constexpr size_t kAlign = 8;
  static constexpr size_t kMaxPooledBytes = 512;
  static constexpr size_t kFirstChunkBytes = 256;
  static constexpr size_t kMaxChunkBytes = 64 * 1024;

  NodePool() = default;
  NodePool(const NodePool&) = delete;
  NodePool& operator=(const NodePool&) = delete;
  ~NodePool();

  // Returns 8-byte aligned, uninitialized memory of at least `bytes` (> 0) bytes.
  void* Allocate(size_t bytes);
  // Returns a block from Allocate(bytes) (same `bytes`) to the pool for reuse.
  void Free(void* block, size_t bytes);
  // Makes the next `bytes` bytes of allocations come from one chunk (for bulk building).
  void Reserve(size_t bytes);

  // Bytes this pool holds from the system: chunks (used or free) plus large blocks.
  size_t BytesReserved() const { return reserved_bytes_; }
  // Bytes currently handed out to callers (rounded up to kAlign).
  size_t BytesInUse() const { return in_use_bytes_; }

 private:
  struct FreeBlock {
    FreeBlock* next;
  };
  static size_t RoundUp(size_t bytes) { return (bytes + kAlign - 1) & ~(kAlign - 1); }
  void ReleaseChunks();

  std::array<FreeBlock*, kMaxPooledBytes / kAlign + 1> free_{};
  std::vector<std::unique_ptr<std::byte[]>> chunks_;
  std::byte* bump_ = nullptr;
  size_t bump_left_ = 0;
  size_t next_chunk_bytes_ = kFirstChunkBytes;
  size_t reserved_bytes_ = 0;
  size_t in_use_bytes_ = 0;
};

}  // namespace skimap

#endif  // SKIMAP_NODE_POOL_H_
