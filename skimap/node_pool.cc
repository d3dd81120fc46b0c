#include "skimap/node_pool.h"

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
    if (next_chunk_bytes_ < kMaxChunkBytes) next_chunk_bytes_ *= 2;
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
}

}  // namespace skimap
