// SkipListCore<K, V>: the compact skip list of SkiMap's x level (its y and z levels are
// sorted runs: YRow, ZRow).
//
// A core is 16 bytes (head, size, height), small enough to hold one per column. It
// does not own an allocator: every mutating call takes the SkipListArena whose pool holds
// the nodes and whose seeded RNG draws node heights, and the owner must call Clear(arena)
// before the core is destroyed (SkipList<K, V> in skip_list.h is the self-contained wrapper
// that does).
//
// Nodes are variable-height towers from the arena's NodePool; a node's height is drawn from
// a geometric distribution with the arena's promotion probability, using the arena's own
// xorshift RNG (seeded by the owner; never the global rand()). The head keeps its level-0
// pointer inline and grows a tower only when the list does, so an empty list uses no pool
// memory and a short list costs just its nodes.
//
// Fingers make ascending batch operations cheap: a Finger remembers the predecessors of the
// last key it visited, so the next, larger key is found by walking forward from there
// instead of from the head (O(log distance) instead of O(log n)).
//
// Thread safety: not thread safe; callers serialize writers against readers (SkiMap does
// it with per-column locks). K needs operator< and operator==.
#ifndef SKIMAP_SKIP_LIST_CORE_H_
#define SKIMAP_SKIP_LIST_CORE_H_

#include <cassert>
#include <cstdint>
#include <new>
#include <utility>

#include "skimap/node_pool.h"

namespace skimap {

inline constexpr int kMaxSkipListHeight = 24;

struct SkipListOptions {
  // Tallest tower a node may get, 1..kMaxSkipListHeight. log_{1/p}(expected size) suffices.
  int max_height = 16;
  // Probability that a node reaches the next level, in [0, 1]. Smaller values save
  // memory (1/(1-p) forward pointers per node on average) at the cost of longer searches.
  // A node is never taller than 1 + log_{1/p}(size + 1) of the list it joins.
  double promotion_probability = 0.25;
  // Seed of the RNG that draws node heights.
  uint32_t seed = 0x2545F491u;
};

// The memory, the height policy and the RNG shared by a family of lists. Not thread safe.
class SkipListArena {
 public:
  explicit SkipListArena(const SkipListOptions& options = {})
      : rng_(options.seed == 0 ? 0x9E3779B9u : options.seed),
        max_height_(options.max_height < 1                    ? 1
                    : options.max_height > kMaxSkipListHeight ? kMaxSkipListHeight
                                                              : options.max_height),
        threshold_(ProbabilityToThreshold(options.promotion_probability)) {
    // min_size_[h]: smallest list size at which a new node may be taller than h, i.e.
    // size + 1 >= (1/p)^h.
    const double p = options.promotion_probability;
    double span = 1;
    for (int h = 0; h < kMaxSkipListHeight; ++h) {
      min_size_[h] = span - 1 >= UINT32_MAX ? UINT32_MAX : static_cast<uint32_t>(span - 1);
      span = p > 0 && p < 1 ? span / p : (p >= 1 ? 1 : 4294967296.0);
    }
  }

  NodePool& pool() { return pool_; }
  const NodePool& pool() const { return pool_; }
  int max_height() const { return max_height_; }

  // Height for a new node of a list now holding `size` nodes: geometric with the promotion
  // probability, drawn from this arena's xorshift RNG (deterministic for a given seed and
  // operation sequence), and at most 1 + log_{1/p}(size + 1) ("fix the dice", Pugh 1990):
  // a level is worth having only once the list is long enough to skip along it. Short
  // lists thus stay one level high, with their head inline.
  int RandomHeight(uint32_t size) {
    int h = 1;
    while (h < max_height_ && size >= min_size_[h] && NextRandom() < threshold_) ++h;
    return h;
  }

 private:
  static uint32_t ProbabilityToThreshold(double p) {
    if (!(p > 0.0)) return 0;
    if (p >= 1.0) return UINT32_MAX;
    return static_cast<uint32_t>(p * 4294967296.0);
  }
  uint32_t NextRandom() {
    rng_ ^= rng_ << 13;
    rng_ ^= rng_ >> 17;
    rng_ ^= rng_ << 5;
    return rng_;
  }

  NodePool pool_;
  uint32_t rng_;
  int max_height_;
  uint32_t threshold_;
  uint32_t min_size_[kMaxSkipListHeight];
};

template <class K, class V>
class SkipListCore {
 public:
  struct Node {
    K key;
    uint8_t height;
    V value;
    Node* next[1];  // really `height` entries: the tower is allocated past the struct
  };
  // Predecessors of the last visited key per level; nullptr stands for the head. Only the
  // first `valid` entries are meaningful (a fresh finger costs nothing to make).
  struct Finger {
    int valid = 0;
    Node* preds[kMaxSkipListHeight];
  };

  SkipListCore() = default;
  SkipListCore(SkipListCore&& other) noexcept { *this = std::move(other); }
  SkipListCore& operator=(SkipListCore&& other) noexcept {
    std::swap(head_, other.head_);  // an inline head moves by value, a tower by pointer
    std::swap(size_, other.size_);
    std::swap(height_, other.height_);
    std::swap(head_capacity_, other.head_capacity_);
    return *this;
  }
  SkipListCore(const SkipListCore&) = delete;
  SkipListCore& operator=(const SkipListCore&) = delete;
  // REQUIRES: Clear(arena) was called (or the list is empty).
  ~SkipListCore() { assert(size_ == 0 && head_capacity_ == 0); }

  uint32_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  int height() const { return height_; }

  // First node, or nullptr. Iterate with node->next[0].
  Node* First() const { return head_capacity_ == 0 ? nullptr : Links(nullptr)[0]; }

  // Last node, or nullptr. O(log n).
  Node* Last() const {
    Node* cur = nullptr;
    for (int l = height_ - 1; l >= 0; --l) {
      for (Node* n = Links(cur)[l]; n != nullptr; n = Links(cur)[l]) cur = n;
    }
    return cur;
  }

  // First node whose key is >= key (find-nearest), or nullptr.
  Node* LowerBound(const K& key) const {
    if (head_capacity_ == 0) return nullptr;
    Node** links = Links(nullptr);
    for (int l = height_ - 1; l >= 0; --l) {
      for (Node* n = links[l]; n != nullptr && n->key < key; n = links[l]) links = n->next;
    }
    return links[0];
  }

  // Node with exactly `key`, or nullptr.
  Node* Find(const K& key) const {
    Node* n = LowerBound(key);
    return (n != nullptr && n->key == key) ? n : nullptr;
  }

  // Moves `finger` to the predecessors of `key`; returns the first node >= key or nullptr.
  // REQUIRES: `finger` is fresh, or its last key was <= `key` and the list was changed
  // since then only through this finger.
  Node* Seek(Finger& finger, const K& key) const {
    if (head_capacity_ == 0) return nullptr;
    Node* cur = nullptr;  // the head
    Node** links = Links(nullptr);
    for (int l = height_ - 1; l >= 0; --l) {
      if (l < finger.valid) {
        Node* p = finger.preds[l];
        if (p != nullptr && (cur == nullptr || cur->key < p->key)) {
          cur = p;
          links = p->next;
        }
      }
      for (Node* n = links[l]; n != nullptr && n->key < key; n = links[l]) {
        cur = n;
        links = n->next;
      }
      finger.preds[l] = cur;
    }
    if (finger.valid < height_) finger.valid = height_;
    return links[0];
  }

  // Returns the node for `key`, inserting one with a default-constructed value if missing;
  // `*inserted` tells which. Same finger contract as Seek.
  Node* FindOrInsert(SkipListArena& arena, Finger& finger, const K& key, bool* inserted) {
    Node* n = Seek(finger, key);
    if (n != nullptr && n->key == key) {
      *inserted = false;
      return n;
    }
    *inserted = true;
    const int h = arena.RandomHeight(size_);
    if (h > head_capacity_) GrowHead(arena, h);
    for (int l = height_; l < h; ++l) finger.preds[l] = nullptr;
    if (h > height_) height_ = static_cast<uint8_t>(h);
    if (finger.valid < height_) finger.valid = height_;
    void* mem = arena.pool().Allocate(NodeBytes(h));
    Node* node = static_cast<Node*>(mem);
    new (&node->key) K(key);
    node->height = static_cast<uint8_t>(h);
    new (&node->value) V();
    for (int l = 0; l < h; ++l) {
      Node** links = Links(finger.preds[l]);
      node->next[l] = links[l];
      links[l] = node;
    }
    ++size_;
    return node;
  }

  // Removes `key` if present and returns its memory to the pool. Same finger contract.
  bool Erase(SkipListArena& arena, Finger& finger, const K& key) {
    Node* n = Seek(finger, key);
    if (n == nullptr || !(n->key == key)) return false;
    for (int l = 0; l < n->height; ++l) Links(finger.preds[l])[l] = n->next[l];
    DestroyNode(arena, n);
    --size_;
    while (height_ > 0 && Links(nullptr)[height_ - 1] == nullptr) --height_;
    if (size_ == 0) FreeHead(arena);
    return true;
  }

  // Destroys every node and the head tower.
  void Clear(SkipListArena& arena) {
    Node* n = First();
    while (n != nullptr) {
      Node* next = n->next[0];
      DestroyNode(arena, n);
      n = next;
    }
    size_ = 0;
    height_ = 0;
    FreeHead(arena);
  }

  // Pool bytes of one node of height h (for memory accounting and tests).
  static constexpr size_t NodeBytes(int h) { return sizeof(Node) + (h - 1) * sizeof(Node*); }

 private:
  // The head's forward pointers: inline while the list is one level high (most y lists),
  // an allocated tower beyond that.
  union Head {
    Node* first;
    Node** tower;
  };

  Node** Links(Node* n) const {
    if (n != nullptr) return n->next;
    return head_capacity_ <= 1 ? const_cast<Node**>(&head_.first) : head_.tower;
  }

  void GrowHead(SkipListArena& arena, int h) {
    if (h <= 1) {
      head_.first = nullptr;
      head_capacity_ = 1;
      return;
    }
    auto** tower = static_cast<Node**>(arena.pool().Allocate(h * sizeof(Node*)));
    for (int l = 0; l < h; ++l) tower[l] = l < height_ ? Links(nullptr)[l] : nullptr;
    if (head_capacity_ > 1) arena.pool().Free(head_.tower, head_capacity_ * sizeof(Node*));
    head_.tower = tower;
    head_capacity_ = static_cast<uint8_t>(h);
  }
  void FreeHead(SkipListArena& arena) {
    if (head_capacity_ > 1) arena.pool().Free(head_.tower, head_capacity_ * sizeof(Node*));
    head_.first = nullptr;
    head_capacity_ = 0;
  }
  static void DestroyNode(SkipListArena& arena, Node* n) {
    const int h = n->height;
    n->value.~V();
    n->key.~K();
    arena.pool().Free(n, NodeBytes(h));
  }

  Head head_{nullptr};
  uint32_t size_ = 0;
  uint8_t height_ = 0;
  uint8_t head_capacity_ = 0;  // 0: empty, 1: inline head, > 1: tower of that height
};

}  // namespace skimap

#endif  // SKIMAP_SKIP_LIST_CORE_H_
