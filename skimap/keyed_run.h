// KeyedRun<T>: a sorted run of (int32 key, T value) entries in one block from a NodePool:
// the storage of SkiMap's y level (YRow, the rows of an x column) and z level (ZRow, the
// voxels of an (x, y) column). The derived classes merge batches into it.
//
//   KeyedRun<float> run;
//   run.Reserve(pool, 3);
//   run.Append(pool, 2, 0.5f);                   // keys ascending
//   const auto* e = run.Find(2);                 // O(log n); nullptr if absent
//   run.Clear(pool);                             // before destruction
//
// Memory: the entries plus up to half as many unused ones after growth (growth by 1.5x
// keeps the inserts of a growing run amortized O(1)). Blocks over NodePool::kMaxPooledBytes
// come from the heap (NodePool does that). The run itself is 16 bytes.
//
// Thread safety: not thread safe; SkiMap serializes writers with readers per x column.
// The owner must call Clear(pool) before destroying a run that holds memory.
#ifndef SKIMAP_KEYED_RUN_H_
#define SKIMAP_KEYED_RUN_H_

#include <algorithm>
#include <cassert>
#include <cstddef>
#include <cstdint>
#include <new>
#include <utility>

#include "skimap/node_pool.h"

namespace skimap {

template <class T>
class KeyedRun {
 public:
  struct Entry {
    int32_t key;
    T value;
  };

  KeyedRun() = default;
  KeyedRun(KeyedRun&& other) noexcept { *this = std::move(other); }
  KeyedRun& operator=(KeyedRun&& other) noexcept {
    std::swap(data_, other.data_);
    std::swap(size_, other.size_);
    std::swap(capacity_, other.capacity_);
    return *this;
  }
  KeyedRun(const KeyedRun&) = delete;
  KeyedRun& operator=(const KeyedRun&) = delete;
  // REQUIRES: Clear(pool) was called (or the run never held memory).
  ~KeyedRun() { assert(capacity_ == 0); }

  uint32_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  const Entry* begin() const { return data_; }
  const Entry* end() const { return data_ + size_; }
  // Starts loading the first entries into the cache.
  void PrefetchHead() const { __builtin_prefetch(data_); }

  // First entry with key >= k, or end().
  const Entry* LowerBound(int32_t k) const { return LowerBoundIn(data_, data_ + size_, k); }
  // The entries with lo <= key <= hi, as [first, last). One bound per end: a loop over
  // the range then has a single exit (compilers keep a caller's accumulator in a register
  // over such loops, not over a loop that also tests each key).
  std::pair<const Entry*, const Entry*> Range(int32_t lo, int32_t hi) const {
    const Entry* first = LowerBound(lo);
    const Entry* last = end();
    if (first != last && (last - 1)->key > hi) {
      last = hi == INT32_MAX ? last : LowerBoundIn(first, last, hi + 1);
    }
    return {first, last};
  }
  // The entry with key k, or nullptr.
  const Entry* Find(int32_t k) const {
    const Entry* e = LowerBound(k);
    return e != end() && e->key == k ? e : nullptr;
  }

  // Room for n entries in all (no effect when there is already).
  void Reserve(NodePool& pool, uint32_t n) {
    if (n > capacity_) Reallocate(pool, n);
  }
  // Appends (k, value). REQUIRES: k greater than every key of the run.
  void Append(NodePool& pool, int32_t k, T value) {
    assert(size_ == 0 || data_[size_ - 1].key < k);
    if (size_ == capacity_) Reallocate(pool, Grown(size_ + 1));
    new (&data_[size_]) Entry{k, std::move(value)};
    ++size_;
  }

  // Destroys every entry and returns the block to the pool. (YRow clears its rows first.)
  void Clear(NodePool& pool) {
    for (uint32_t i = 0; i < size_; ++i) data_[i].~Entry();
    if (capacity_ > 0) pool.Free(data_, Bytes(capacity_));
    data_ = nullptr;
    size_ = capacity_ = 0;
  }

  static constexpr size_t Bytes(uint32_t entries) { return size_t{entries} * sizeof(Entry); }
  // What a block of `entries` takes from a NodePool's chunks: its rounded size, or 0 when
  // it is too large for the pool and comes from the heap (for NodePool::Reserve).
  static constexpr size_t PooledBytes(uint32_t entries) {
    const size_t bytes = (Bytes(entries) + NodePool::kAlign - 1) & ~(NodePool::kAlign - 1);
    return bytes <= NodePool::kMaxPooledBytes ? bytes : 0;
  }

 protected:
  // Binary search while the range is long, then a linear scan (runs are mostly short).
  static Entry* LowerBoundIn(Entry* first, Entry* last, int32_t k) {
    size_t n = static_cast<size_t>(last - first);
    while (n > 8) {
      const size_t half = n / 2;
      if (first[half].key < k) {
        first += half + 1;
        n -= half + 1;
      } else {
        n = half;
      }
    }
    while (first != last && first->key < k) ++first;
    return first;
  }
  static const Entry* LowerBoundIn(const Entry* first, const Entry* last, int32_t k) {
    return LowerBoundIn(const_cast<Entry*>(first), const_cast<Entry*>(last), k);
  }
  // LowerBoundIn for a key expected near `first` (a batch's next key): probes the 1st,
  // 2nd, 4th, 8th ... entries from `first`, then searches the last doubling. O(log d) for an answer
  // d ahead.
  static Entry* GallopIn(Entry* first, Entry* last, int32_t k) {
    const size_t n = static_cast<size_t>(last - first);
    size_t lo = 0, step = 1;
    while (step <= n && first[step - 1].key < k) {
      lo = step;
      step *= 2;
    }
    return LowerBoundIn(first + lo, first + std::min(step - 1, n), k);
  }

  uint32_t Grown(uint32_t needed) const { return std::max(needed, capacity_ + capacity_ / 2); }

  void Reallocate(NodePool& pool, uint32_t capacity) {
    assert(capacity >= size_);
    Entry* fresh = static_cast<Entry*>(pool.Allocate(Bytes(capacity)));
    for (uint32_t i = 0; i < size_; ++i) {
      new (&fresh[i]) Entry(std::move(data_[i]));
      data_[i].~Entry();
    }
    if (capacity_ > 0) pool.Free(data_, Bytes(capacity_));
    data_ = fresh;
    capacity_ = capacity;
  }
  // Moves entry `from` into the unconstructed slot `to`.
  void Relocate(uint32_t from, uint32_t to) {
    new (&data_[to]) Entry(std::move(data_[from]));
    data_[from].~Entry();
  }

  Entry* data_ = nullptr;
  uint32_t size_ = 0;
  uint32_t capacity_ = 0;
};

}  // namespace skimap

#endif  // SKIMAP_KEYED_RUN_H_
