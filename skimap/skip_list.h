// SkipList<K, V>: an ordered map as a skip list that owns its node pool.
//
//   SkipList<int, std::string> list({.max_height = 12, .promotion_probability = 0.5});
//   list.Insert(3, "c");                        // insert or overwrite
//   if (const std::string* v = list.Find(3)) …  // exact lookup
//   list.LowerBound(2);                          // find-nearest: first key >= 2
//   list.ForEachInRange(1, 5, fn);               // ordered range scan, bounds inclusive
//   list.Erase(3);                               // frees the node back to the pool
//
// Iteration is in ascending key order. Nodes come from a private NodePool (see
// node_pool.h) and erased nodes are reused by later inserts.
//
// Thread safety: not thread safe. Concurrent const calls are safe; any mutation needs
// exclusive access.
#ifndef SKIMAP_SKIP_LIST_H_
#define SKIMAP_SKIP_LIST_H_

#include <cstddef>
#include <utility>

#include "skimap/skip_list_core.h"

namespace skimap {

template <class K, class V>
class SkipList {
 public:
  using Core = SkipListCore<K, V>;
  using Node = typename Core::Node;

  explicit SkipList(const SkipListOptions& options = {}) : arena_(options) {}
  ~SkipList() { core_.Clear(arena_); }
  SkipList(const SkipList&) = delete;
  SkipList& operator=(const SkipList&) = delete;

  size_t size() const { return core_.size(); }
  bool empty() const { return core_.empty(); }

  // Inserts key -> value, overwriting an existing value. Returns true if the key was new.
  bool Insert(const K& key, V value) {
    typename Core::Finger finger;
    bool inserted = false;
    Node* n = core_.FindOrInsert(arena_, finger, key, &inserted);
    n->value = std::move(value);
    return inserted;
  }

  // Value stored under `key`, or nullptr. The pointer is valid until the key is erased.
  V* Find(const K& key) {
    Node* n = core_.Find(key);
    return n == nullptr ? nullptr : &n->value;
  }
  const V* Find(const K& key) const {
    const Node* n = core_.Find(key);
    return n == nullptr ? nullptr : &n->value;
  }

  // The entry with the smallest key >= `key` (find-nearest), or nullptr.
  const Node* LowerBound(const K& key) const { return core_.LowerBound(key); }
  const Node* First() const { return core_.First(); }
  const Node* Last() const { return core_.Last(); }

  // Removes `key`; returns false if it was absent. Its memory is reused by later inserts.
  bool Erase(const K& key) {
    typename Core::Finger finger;
    return core_.Erase(arena_, finger, key);
  }

  void Clear() { core_.Clear(arena_); }

  // Calls fn(key, value) for every entry with lo <= key <= hi, in ascending order.
  template <class Fn>
  void ForEachInRange(const K& lo, const K& hi, Fn&& fn) const {
    for (const Node* n = core_.LowerBound(lo); n != nullptr && !(hi < n->key); n = n->next[0]) {
      fn(n->key, n->value);
    }
  }
  // Calls fn(key, value) for every entry in ascending order.
  template <class Fn>
  void ForEach(Fn&& fn) const {
    for (const Node* n = core_.First(); n != nullptr; n = n->next[0]) fn(n->key, n->value);
  }

  // Bytes of memory held: the pool's chunks plus this object.
  size_t MemoryUsage() const { return sizeof(*this) + arena_.pool().BytesReserved(); }

 private:
  SkipListArena arena_;
  Core core_;
};

}  // namespace skimap

#endif  // SKIMAP_SKIP_LIST_H_
