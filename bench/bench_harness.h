// The benchmark bodies shared by every structure, so each one runs the same loop on the same
// points. A structure is wrapped in a small adapter with the natural API of its library:
//
//   struct Adapter {
//     explicit Adapter(double resolution_m);
//     void Insert(const Cloud& world_points);          // integrate a frame / add points
//     size_t RadiusCount(const PointF& c, double r) const;   // voxels (points) within r
//     size_t Voxels() const;                            // voxels (points) stored
//     size_t LibBytes() const;                          // the library's own estimate, 0 if none
//     void ReleaseScratch();                            // free reusable buffers (for memory)
//     void Reset();  // optional: empty the structure but keep reusable scratch buffers
//     // optional, for maps (detected with requires-expressions):
//     size_t BoxCount(const PointF& lo, const PointF& hi) const;
//     double VisitAll() const;  size_t HeightMap() const;  size_t OccupancyGrid() const;
//   };
//
// Run*<Adapter> are the loops; bench_register.h registers them as BM_<Operation>_Name/<arg>
// benchmarks (insert args are the resolution in mm; radius args the radius in cm; box
// args the box side in cm). Structures
// used by queries are built once per process on first use and cached, together with the
// heap bytes their build allocated (mallinfo2 difference; see HeapBytesInUse()).
//
// Thread safety: Google Benchmark runs these on its main thread only.
#ifndef SKIMAP_BENCH_BENCH_HARNESS_H_
#define SKIMAP_BENCH_BENCH_HARNESS_H_

#include <benchmark/benchmark.h>

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "bench/bench_data.h"

namespace skimap::bench {

// The query workloads and their fixed resolutions.
enum class Workload { kUniform, kSurface, kBig };
inline constexpr int kUniformResMm = 10;  // 1 M uniform points, 1 cm voxels
inline constexpr int kSurfaceResMm = 10;  // room sweep surface map, 1 cm (active sphere)
inline constexpr int kBigResMm = 10;      // >= 10 M voxel warehouse map
inline constexpr size_t kQueryCount = 1024;

// Distinct voxel centres of the room sweep at `res_mm` (what a point index stores to
// answer the same queries as a voxel map).
const Cloud& SurfaceVoxelCenters(int res_mm);
// Query centres drawn from the workload's points (fixed seeds).
const Cloud& QueryCentersFor(Workload w);
// The clouds a map is built from for a workload (frames, or one big cloud).
std::vector<const Cloud*> WorkloadClouds(Workload w);
const char* WorkloadName(Workload w);
// {RoomFrame()}: the room frame as a one-frame sequence.
const std::vector<Cloud>& RoomFrameList();

// Point indexes (kd-tree, PCL octree) are built from voxel centres on surface workloads.
template <class S>
concept PointIndex = S::kStoresPoints;

template <class S>
struct Built {
  std::unique_ptr<S> s;
  size_t heap_bytes = 0;  // heap allocated by the build (mallinfo2 difference)
};

// Builds S for (workload, resolution) once and caches it.
template <class S>
const Built<S>& Cached(Workload w, int res_mm) {
  static std::map<std::pair<Workload, int>, Built<S>> cache;
  auto it = cache.find({w, res_mm});
  if (it != cache.end()) return it->second;
  std::vector<const Cloud*> clouds = WorkloadClouds(w);
  if constexpr (PointIndex<S>) {
    if (w != Workload::kUniform) clouds = {&SurfaceVoxelCenters(res_mm)};
  }
  Built<S> b;
  const size_t before = HeapBytesInUse();
  b.s = std::make_unique<S>(res_mm * 1e-3);
  for (const Cloud* c : clouds) b.s->Insert(*c);
  b.s->ReleaseScratch();
  b.heap_bytes = HeapBytesInUse() - before;
  return cache.emplace(std::pair{w, res_mm}, std::move(b)).first->second;
}

// Inserts one frame per iteration (cycling through `frames`), into an empty structure
// (steady = false; the reset is not timed) or into one that already holds every frame.
template <class S>
void RunInsert(benchmark::State& state, const std::vector<Cloud>& frames, bool steady) {
  if (frames.empty()) {
    state.SkipWithError(("no frames: " + YcbvError()).c_str());
    return;
  }
  const double res = state.range(0) * 1e-3;
  std::unique_ptr<S> s;
  auto reset = [&] {
    if constexpr (requires { s->Reset(); }) {
      if (s != nullptr) {
        s->Reset();  // keeps the structure's reusable scratch, as a live map worker would
      } else {
        s = std::make_unique<S>(res);
      }
    } else {
      s.reset();
      s = std::make_unique<S>(res);
    }
    if (steady) {
      for (const Cloud& f : frames) s->Insert(f);
    }
  };
  reset();
  size_t i = 0, points = 0;
  for (auto _ : state) {
    const Cloud& f = frames[i++ % frames.size()];
    if (!steady) {
      state.PauseTiming();
      reset();
      state.ResumeTiming();
    }
    s->Insert(f);
    points += f.size();
  }
  state.SetItemsProcessed(static_cast<int64_t>(points));
  state.counters["points"] = static_cast<double>(points) / static_cast<double>(state.iterations());
  state.counters["voxels"] = static_cast<double>(s->Voxels());
}

template <class S>
void RunRadius(benchmark::State& state, Workload w) {
  const S& s = *Cached<S>(w, w == Workload::kUniform ? kUniformResMm : kSurfaceResMm).s;
  const Cloud& queries = QueryCentersFor(w);
  const double r = state.range(0) * 1e-2;
  size_t i = 0, hits = 0;
  for (auto _ : state) hits += s.RadiusCount(queries[i++ % queries.size()], r);
  state.counters["hits"] = static_cast<double>(hits) / static_cast<double>(state.iterations());
}

template <class S>
void RunBox(benchmark::State& state) {
  const S& s = *Cached<S>(Workload::kBig, kBigResMm).s;
  const Cloud& queries = QueryCentersFor(Workload::kBig);
  const float half = state.range(0) * 0.5e-2f;
  size_t i = 0, hits = 0;
  for (auto _ : state) {
    const PointF& c = queries[i++ % queries.size()];
    hits += s.BoxCount({c.x - half, c.y - half, -0.1f}, {c.x + half, c.y + half, 3.1f});
  }
  state.counters["hits"] = static_cast<double>(hits) / static_cast<double>(state.iterations());
}

// Runs fn(const S&) -> number on the big map; reports the number as "result".
template <class S, class Fn>
void RunWhole(benchmark::State& state, Fn fn) {
  const Built<S>& b = Cached<S>(Workload::kBig, kBigResMm);
  // A volatile sink, not DoNotOptimize(double&): with GCC its "+m,r" constraint can leave
  // a stale stack slot in `result` (google/benchmark#903, GCC PR 92597).
  volatile double result = 0;
  for (auto _ : state) result = static_cast<double>(fn(*b.s));
  state.counters["result"] = result;
  state.counters["voxels"] = static_cast<double>(b.s->Voxels());
}

// Reports the build's heap bytes per voxel (and the library's own estimate).
template <class S>
void RunMemory(benchmark::State& state, Workload w) {
  const Built<S>& b = Cached<S>(w, static_cast<int>(state.range(0)));
  for (auto _ : state) benchmark::DoNotOptimize(b.s.get());
  const double voxels = static_cast<double>(b.s->Voxels());
  state.counters["voxels"] = voxels;
  state.counters["heap_bytes"] = static_cast<double>(b.heap_bytes);
  state.counters["bytes_per_voxel"] = static_cast<double>(b.heap_bytes) / voxels;
  state.counters["lib_bytes_per_voxel"] = static_cast<double>(b.s->LibBytes()) / voxels;
}

}  // namespace skimap::bench

#endif  // SKIMAP_BENCH_BENCH_HARNESS_H_
