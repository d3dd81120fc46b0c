// Template definitions for skimap.h. Include skimap.h, not this file.
#ifndef SKIMAP_SKIMAP_IMPL_H_
#define SKIMAP_SKIMAP_IMPL_H_

#include <algorithm>
#include <atomic>
#include <utility>

namespace skimap {

namespace internal {
// A write number no column of any map has had: versions stay unique across maps, and
// across a column removed and created again.
inline uint64_t NextColumnVersion() {
  static std::atomic<uint64_t> writes{0};
  return writes.fetch_add(1, std::memory_order_relaxed) + 1;
}
// Below this many voxels a batch is applied on the calling thread alone.
inline constexpr size_t kParallelMinItems = 4096;
}  // namespace internal

template <Voxel V>
struct SkiMap<V>::Column {
  Column() = default;
  ~Column() ABSL_NO_THREAD_SAFETY_ANALYSIS { ys.Clear(pool); }
  mutable RwLock mu;
  // The process-wide write number of the last write to this column, and of the last write
  // to each of its y blocks (y >> kYBlockShift; sorted by block): ForEachColumnVersion.
  std::atomic<uint64_t> version{0};
  std::vector<std::pair<int32_t, uint64_t>> y_blocks ABSL_GUARDED_BY(mu);
  NodePool pool ABSL_GUARDED_BY(mu);  // the y run and every z run of the column
  YList ys ABSL_GUARDED_BY(mu);
  size_t heap_bytes ABSL_GUARDED_BY(mu) = 0;  // sum of V::HeapBytes in this column
};

template <Voxel V>
struct SkiMap<V>::Run {
  int32_t x;
  size_t begin, end;
  Column* column;
  WriteStats stats;
};

template <Voxel V>
SkiMap<V>::SkiMap(const Options& options)
    : options_(options), grid_(options.resolution, options.origin), xs_(options.lists) {}

template <Voxel V>
SkiMap<V>::~SkiMap() = default;

template <Voxel V>
absl::Status SkiMap<V>::Integrate(const Point3& p, const V& data) {
  VoxelKey key;
  if (!grid_.ToKey(p, &key)) {
    return absl::InvalidArgumentError("point: outside the map's key range or not finite");
  }
  IntegrateKey(key, data);
  return absl::OkStatus();
}

template <Voxel V>
absl::Status SkiMap<V>::Deintegrate(const Point3& p, const V& data) {
  VoxelKey key;
  if (!grid_.ToKey(p, &key)) {
    return absl::InvalidArgumentError("point: outside the map's key range or not finite");
  }
  DeintegrateKey(key, data);
  return absl::OkStatus();
}

template <Voxel V>
WriteStats SkiMap<V>::IntegrateKey(const VoxelKey& key, const V& data) {
  const typename VoxelBatch<V>::Item item{key, data};
  WriterLock lock(&writer_mu_);
  return Apply(&item, 1, /*integrate=*/true);
}

template <Voxel V>
WriteStats SkiMap<V>::DeintegrateKey(const VoxelKey& key, const V& data) {
  const typename VoxelBatch<V>::Item item{key, data};
  WriterLock lock(&writer_mu_);
  return Apply(&item, 1, /*integrate=*/false);
}

template <Voxel V>
WriteStats SkiMap<V>::Integrate(const VoxelBatch<V>& batch) {
  assert(batch.finalized());
  WriterLock lock(&writer_mu_);
  return Apply(batch.items().data(), batch.size(), /*integrate=*/true);
}

template <Voxel V>
WriteStats SkiMap<V>::Deintegrate(const VoxelBatch<V>& batch) {
  assert(batch.finalized());
  WriterLock lock(&writer_mu_);
  return Apply(batch.items().data(), batch.size(), /*integrate=*/false);
}

template <Voxel V>
bool SkiMap<V>::Erase(const VoxelKey& key) {
  WriterLock lock(&writer_mu_);
  std::optional<V> current = Find(key);
  if (!current) return false;
  const typename VoxelBatch<V>::Item item{key, *current};
  // Subtracting a voxel from itself empties it, for every voxel type.
  Apply(&item, 1, /*integrate=*/false);
  return true;
}

template <Voxel V>
void SkiMap<V>::Clear() {
  WriterLock lock(&writer_mu_);
  WriterLock x_lock(&x_mu_);
  xs_.Clear();
  size_.store(0, std::memory_order_relaxed);
}

template <Voxel V>
void SkiMap<V>::Compact() {
  WriterLock lock(&writer_mu_);
  std::vector<std::pair<int32_t, Column*>> columns;
  {
    ReaderLock x_lock(&x_mu_);
    for (auto* xn = xs_.First(); xn != nullptr; xn = xn->next[0]) {
      columns.emplace_back(xn->key, xn->value.get());
    }
  }
  for (auto [x, old] : columns) {
    std::unique_ptr<Column> fresh = CopyColumn(*old);
    WriterLock x_lock(&x_mu_);  // no reader is inside any column while we hold this
    std::swap(*xs_.Find(x), fresh);
  }  // `fresh` now holds the old column: destroyed here, outside the lock
}

template <Voxel V>
std::unique_ptr<typename SkiMap<V>::Column> SkiMap<V>::CopyColumn(const Column& old)
    ABSL_NO_THREAD_SAFETY_ANALYSIS {
  // `fresh` is not shared yet: no lock needed on it.
  auto fresh = std::make_unique<Column>();
  ReaderLock lock(&old.mu);
  // One chunk for the y run and the z runs small enough to come from the pool.
  size_t pooled = YList::PooledBytes(old.ys.size());
  for (const auto& row : old.ys) pooled += ZList::PooledBytes(row.value.size());
  fresh->pool.Reserve(pooled);
  fresh->ys.Reserve(fresh->pool, old.ys.size());  // exactly: no growth slack
  for (const auto& row : old.ys) {
    ZList z;
    z.Reserve(fresh->pool, row.value.size());
    for (const auto& e : row.value) z.Append(fresh->pool, e.key, e.value);
    fresh->ys.Append(fresh->pool, row.key, std::move(z));
  }
  fresh->heap_bytes = old.heap_bytes;
  fresh->version.store(old.version.load(std::memory_order_acquire), std::memory_order_release);
  fresh->y_blocks = old.y_blocks;
  return fresh;
}

template <Voxel V>
std::optional<V> SkiMap<V>::Find(const VoxelKey& key) const {
  ReaderLock x_lock(&x_mu_);
  const std::unique_ptr<Column>* c = xs_.Find(key.x);
  if (c == nullptr) return std::nullopt;
  const Column& column = **c;
  ReaderLock lock(&column.mu);
  const auto* row = column.ys.Find(key.y);
  if (row == nullptr) return std::nullopt;
  const auto* e = row->value.Find(key.z);
  if (e == nullptr) return std::nullopt;
  return e->value;
}

template <Voxel V>
std::optional<KeyBox> SkiMap<V>::Bounds() const {
  return BoundsOf(/*with_z=*/true);
}

template <Voxel V>
std::optional<KeyBox> SkiMap<V>::FootprintBounds() const {
  return BoundsOf(/*with_z=*/false);
}

template <Voxel V>
std::optional<KeyBox> SkiMap<V>::BoundsOf(bool with_z) const {
  ReaderLock x_lock(&x_mu_);
  KeyBox b;  // z keeps the whole key range unless with_z
  b.min.y = kMaxKey;
  b.max.y = kMinKey;
  if (with_z) b.min.z = kMaxKey, b.max.z = kMinKey;
  bool any = false;
  for (auto* xn = xs_.First(); xn != nullptr; xn = xn->next[0]) {
    const Column& column = *xn->value;
    ReaderLock lock(&column.mu);
    // A reader can find a column empty: just created, before its batch's write took the
    // column lock, or emptied by a write and not yet removed.
    if (column.ys.empty()) continue;
    if (!any) b.min.x = xn->key;
    any = true;
    b.max.x = xn->key;
    b.min.y = std::min(b.min.y, column.ys.begin()->key);
    b.max.y = std::max(b.max.y, (column.ys.end() - 1)->key);
    if (!with_z) continue;
    for (const auto& row : column.ys) {
      b.min.z = std::min(b.min.z, row.value.begin()->key);
      b.max.z = std::max(b.max.z, (row.value.end() - 1)->key);
    }
  }
  if (!any) return std::nullopt;
  return b;
}

template <Voxel V>
size_t SkiMap<V>::MemoryUsage() const {
  ReaderLock x_lock(&x_mu_);
  size_t bytes = sizeof(*this) - sizeof(xs_) + xs_.MemoryUsage();
  for (auto* xn = xs_.First(); xn != nullptr; xn = xn->next[0]) {
    const Column& column = *xn->value;
    ReaderLock lock(&column.mu);
    bytes += sizeof(Column) + column.pool.BytesReserved() + column.heap_bytes;
  }
  return bytes;
}

}  // namespace skimap

#include "skimap/skimap_search_impl.h"  // IWYU pragma: export
#include "skimap/skimap_write_impl.h"   // IWYU pragma: export

#endif  // SKIMAP_SKIMAP_IMPL_H_
