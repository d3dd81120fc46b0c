// SkiMap<V>: a sparse voxel map as a tree of ordered levels, x -> y -> z, after the tree of
// skip lists of Gregorio and Di Stefano (ICRA 2017): a skip list of x columns over sorted
// runs of y rows and z voxels. One voxel value V per occupied integer key.
//
//   SkiMap<RGBWeightedVoxel> map({.resolution = 0.02});
//   VoxelBatch<RGBWeightedVoxel> batch;  ... batch.Finalize();
//   map.Integrate(batch);                       // voxel += data, per distinct voxel
//   map.RadiusSearch({1, 2, 0.5}, 0.2, [](const VoxelKey& k, const RGBWeightedVoxel& v) {});
//   map.Deintegrate(batch);                     // voxel -= data; emptied voxels are freed
//
// Structure: the x level is a SkipList of columns; a column holds its y level as one
// sorted run of (y, row) entries (YRow, y_row.h), and each row is the z level of an (x, y)
// column: its voxels as one sorted run of (z, value) entries (ZRow, z_row.h); all memory
// of a column comes from its own NodePool. Every level is ordered by key, with O(log n)
// access. A voxel whose IsEmpty() turns true is erased and its memory reused; an emptied
// row or column is removed too, so de-integrating everything returns the map to its
// empty size.
// Keys and the world <-> key conversion are in grid.h (range ±2^20 per axis).
//
// Concurrency model (tested under TSan in tests/skimap/skimap_concurrency_test.cc):
//  - Writers (Integrate, Deintegrate, Erase, Clear) are serialized by an internal mutex:
//    one logical writer at a time. A batch is applied in parallel over its x columns on the
//    Options::pool threads, each column under that column's writer lock.
//  - Readers (every const method) may run concurrently with each other and with the
//    writer. A reader holds the x-level lock in shared mode for the whole call and each
//    column's lock in shared mode while it visits the column, so it sees every column in a
//    consistent state, though not all columns at the same instant. RadiusSearch and
//    ForEachInBox hold the shared locks of up to 32 columns at once, taken in ascending x;
//    writers never hold a column lock while waiting for another, so this cannot deadlock.
//    The writer takes the x-level lock exclusively only to add or remove columns.
//  - Callbacks run under those shared locks: they must not call writers of the same map.
#ifndef SKIMAP_SKIMAP_H_
#define SKIMAP_SKIMAP_H_

#include <atomic>
#include <cmath>
#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/status/status.h"
#include "base/rw_lock.h"
#include "base/thread_pool.h"
#include "skimap/grid.h"
#include "skimap/skip_list.h"
#include "skimap/voxel.h"
#include "skimap/voxel_batch.h"
#include "skimap/y_row.h"
#include "skimap/z_row.h"

namespace skimap {

template <Voxel V>
class SkiMap {
 public:
  using VoxelType = V;
  struct Options {
    double resolution = 0.05;    // metres per voxel edge, > 0
    Point3 origin;               // world position of the corner of voxel (0, 0, 0)
    SkipListOptions lists;       // height policy and RNG seed of the x level
    ThreadPool* pool = nullptr;  // threads for batch writes (not owned); nullptr = caller
  };
  using ZList = ZRow<V>;  // the z level of one (x, y) column (z_row.h)
  using YList = YRow<V>;  // the y level of one x column (y_row.h)

  // A read-only view of one (x, y) column of voxels, ordered by z.
  class ZColumn {
   public:
    explicit ZColumn(const ZList& list) : list_(list) {}
    // fn(int32_t kz, const V&) for every voxel, ascending z.
    template <class Fn>
    void ForEach(Fn&& fn) const {
      for (const auto& e : list_) fn(e.key, e.value);
    }
    // fn(int32_t kz, const V&) for lo <= kz <= hi, ascending.
    template <class Fn>
    void ForEachInRange(int32_t lo, int32_t hi, Fn&& fn) const {
      const auto [first, last] = list_.Range(lo, hi);
      for (auto* e = first; e != last; ++e) fn(e->key, e->value);
    }
    // The same while fn returns true: stops after the first false.
    template <class Fn>
    void ForEachInRangeWhile(int32_t lo, int32_t hi, Fn&& fn) const {
      const auto [first, last] = list_.Range(lo, hi);
      for (auto* e = first; e != last; ++e) {
        if (!fn(e->key, e->value)) return;
      }
    }
    size_t size() const { return list_.size(); }
    // Key of the highest voxel and the voxel (REQUIRES: size() > 0, always true for the
    // columns ForEachColumn hands out). O(1).
    std::pair<int32_t, const V*> Top() const {
      const auto* e = list_.end() - 1;
      return {e->key, &e->value};
    }

   private:
    const ZList& list_;
  };

  explicit SkiMap(const Options& options);
  ~SkiMap();
  SkiMap(const SkiMap&) = delete;
  SkiMap& operator=(const SkiMap&) = delete;

  const Grid& grid() const { return grid_; }
  const Options& options() const { return options_; }

  // ---- Writers (serialized; see the concurrency model above) ----

  // voxel(p) += data. InvalidArgument if p has no key (outside the key range, NaN).
  [[nodiscard]] absl::Status Integrate(const Point3& p, const V& data);
  // voxel(p) -= data; the voxel is removed when it becomes empty. A missing voxel is left
  // missing. InvalidArgument if p has no key.
  [[nodiscard]] absl::Status Deintegrate(const Point3& p, const V& data);
  WriteStats IntegrateKey(const VoxelKey& key, const V& data);
  WriteStats DeintegrateKey(const VoxelKey& key, const V& data);
  // Applies a finalized batch (REQUIRES: batch.finalized()).
  WriteStats Integrate(const VoxelBatch<V>& batch);
  WriteStats Deintegrate(const VoxelBatch<V>& batch);
  // Removes one voxel; false if it was absent.
  bool Erase(const VoxelKey& key);
  // Removes every voxel.
  void Clear();
  // Rebuilds each column with its y run and z runs laid out in key order in one chunk
  // (runs over 512 bytes from the heap), each at its exact size: after many frames (or
  // de-integrations) they are scattered over the pool, and queries pay a cache miss per row.
  // Content is unchanged. Costs about one copy of the map; readers wait only while a column pointer
  // is swapped. A server runs it when a map is idle or every N frames.
  void Compact();

  // ---- Readers (thread safe, concurrent with the writer) ----

  // Copy of the voxel at `key`, if any.
  std::optional<V> Find(const VoxelKey& key) const;
  // fn(const VoxelKey&, const V&) for every voxel in (x, y, z) order.
  template <class Fn>
  void ForEach(Fn&& fn) const {
    WalkBox(KeyBox{}, fn);
  }
  // fn(const VoxelKey&, const V&) for every voxel with key in `box`, in (x, y, z) order.
  template <class Fn>
  void ForEachInBox(const KeyBox& box, Fn&& fn) const;
  // fn(const VoxelKey&, const V&) for every voxel whose centre is within `radius` metres of
  // `center` (exact Euclidean test), in (x, y, z) order.
  template <class Fn>
  void RadiusSearch(const Point3& center, double radius, Fn&& fn) const;
  // fn(int32_t kx, int32_t ky, const ZColumn&) for every non-empty (x, y) column with
  // x in [min_x, max_x] and y in [min_y, max_y], in (x, y) order.
  template <class Fn>
  void ForEachColumn(int32_t min_x, int32_t max_x, int32_t min_y, int32_t max_y, Fn&& fn) const;
  // fn(int32_t x, uint64_t version, std::span<const std::pair<int32_t, uint64_t>> y_blocks)
  // for every x column (the voxels with key.x == x) in [min_x, max_x], ascending. A
  // column's version changes with every write that touches it and with nothing else
  // (Compact keeps it); y_blocks gives, sorted by block, the version of the last write to
  // each block of ys (y >> kYBlockShift) the column was ever written in. Versions are
  // unique across all maps of the process, so a column removed and created again, or one
  // of another map, never shows an earlier version. What caches of per-column results
  // check (OccupancyGridCache). The span is valid during the call only.
  static constexpr int kYBlockShift = 6;
  template <class Fn>
  void ForEachColumnVersion(int32_t min_x, int32_t max_x, Fn&& fn) const;

  // Number of voxels.
  size_t size() const { return size_.load(std::memory_order_relaxed); }
  bool empty() const { return size() == 0; }
  // Smallest key box holding every voxel; nullopt when empty.
  std::optional<KeyBox> Bounds() const;
  // Like Bounds() on x and y only (z spans the whole key range): what 2D rasters need,
  // found without visiting the z runs.
  std::optional<KeyBox> FootprintBounds() const;
  // Heap and object bytes held by the map: pools (used and free), columns, the x level and
  // memory the voxels own (V::HeapBytes).
  size_t MemoryUsage() const;

 private:
  struct Column;
  struct Run;  // the items of a batch that fall in one column
  using XList = SkipList<int32_t, std::unique_ptr<Column>>;

  WriteStats Apply(const typename VoxelBatch<V>::Item* items, size_t n, bool integrate)
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(writer_mu_);
  static void StampYBlocks(Column& column, const typename VoxelBatch<V>::Item* begin,
                           const typename VoxelBatch<V>::Item* end, uint64_t version);
  // Bounds() (with_z) or FootprintBounds().
  std::optional<KeyBox> BoundsOf(bool with_z) const;
  // The search behind ForEachInBox and RadiusSearch. For each column x in [x0, x1] with
  // col_range(x, ColState*, int32_t* y0, int32_t* y1) true, each y entry in [y0, y1] with
  // row_range(const ColState&, y, RowState*, int32_t* z0, int32_t* z1) true, and each voxel
  // with z in [z0, z1] and keep(const RowState&, z) true: fn(key, value), in (x, y, z) order.
  // Searches many columns and rows at once so that their cache misses overlap.
  template <class ColState, class RowState, class ColFn, class RowFn, class KeepFn, class Fn>
  void SearchColumns(int32_t x0, int32_t x1, ColFn&& col_range, RowFn&& row_range, KeepFn&& keep,
                     Fn&& fn) const;
  // fn(key, value) for every voxel in `box` (not empty), column by column, row by row.
  template <class Fn>
  void WalkBox(const KeyBox& box, Fn&& fn) const;
  static std::unique_ptr<Column> CopyColumn(const Column& old);

  const Options options_;
  const Grid grid_;
  RwLock writer_mu_;
  mutable RwLock x_mu_;
  XList xs_ ABSL_GUARDED_BY(x_mu_);
  std::atomic<size_t> size_{0};
};

}  // namespace skimap

#include "skimap/skimap_impl.h"  // IWYU pragma: export

#endif  // SKIMAP_SKIMAP_H_
