#include "skimap/node_pool.h"

#include <algorithm>
#include <new>

namespace skimap {

NodePool::~NodePool() = default;

void* NodePool::Allocate(size_t bytes) {
  const size_t size = RoundUp(bytes == 0 ? 1 : bytes);
  in_use_bytes_ += size;
  if (size > kMaxPooledBytes) {
    reserved_bytes_ += size;
    return ::operator new(size);
  }
  FreeBlock*& head = free_[size / kAlign];
  if (head != nullptr) {
    FreeBlock* block = head;
    head = block->next;
    return block;
  }
  if (bump_left_ < size) {
    // The tail of the old chunk is too small for this request; it stays unused.
    size_t chunk = next_chunk_bytes_;
    while (chunk < size) chunk *= 2;
    chunks_.push_back(std::make_unique_for_overwrite<std::byte[]>(chunk));
    bump_ = chunks_.back().get();
    bump_left_ = chunk;
    reserved_bytes_ += chunk;
    // Grow by a quarter of what is held, so unused chunk tails stay below ~20%.
    next_chunk_bytes_ =
        std::clamp(reserved_bytes_ / 4 / kAlign * kAlign, kFirstChunkBytes, kMaxChunkBytes);
  }
  void* block = bump_;
  bump_ += size;
  bump_left_ -= size;
  return block;
}

void NodePool::Free(void* block, size_t bytes) {
  const size_t size = RoundUp(bytes == 0 ? 1 : bytes);
  in_use_bytes_ -= size;
  if (size > kMaxPooledBytes) {
    reserved_bytes_ -= size;
    ::operator delete(block);
    return;
  }
  auto* free_block = static_cast<FreeBlock*>(block);
  free_block->next = free_[size / kAlign];
  free_[size / kAlign] = free_block;
  if (in_use_bytes_ == 0) ReleaseChunks();
}

void NodePool::Reserve(size_t bytes) {
  bytes = RoundUp(bytes);
  if (bump_left_ >= bytes) return;
  chunks_.push_back(std::make_unique_for_overwrite<std::byte[]>(bytes));
  bump_ = chunks_.back().get();
  bump_left_ = bytes;
  reserved_bytes_ += bytes;
}

void NodePool::ReleaseChunks() {
  free_.fill(nullptr);
  chunks_.clear();
  bump_ = nullptr;
  bump_left_ = 0;
  next_chunk_bytes_ = kFirstChunkBytes;
  reserved_bytes_ = 0;
}

}  // namespace skimap
