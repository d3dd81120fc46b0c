// The benchmark bodies shared by every structure, so each one runs the same loop on the same
// points. A structure is wrapped in a small adapter with the natural API of its library:
//
//   struct Adapter {
//     explicit Adapter(double resolution_m);
//     void Insert(const Cloud& world_points);  // whole pipeline: points -> structure
//     // Collects the voxels (points) whose centre is within r of c into a reused result
//     // vector, as PCL and nanoflann do, and returns how many.
//     size_t RadiusSearch(const PointF& c, double r) const;
//     size_t Voxels() const;                   // distinct voxels (points) stored
//     size_t LibBytes() const;                 // the library's own estimate, 0 if none
//     void ReleaseScratch();                   // free reusable buffers (for memory)
//     // optional (detected with requires-expressions):
//     void Reset();  // empty the structure but keep reusable scratch buffers
//     // structure only: one update per distinct voxel of a finalized batch, adding its weight
//     void InsertMerged(const VoxelBatch<WeightVoxel>& batch);
//     bool HasVoxel(const VoxelKey& key) const;  // REQUIRED by the insert benchmarks
//     size_t BoxCount(const PointF& lo, const PointF& hi) const;
//     double VisitAll() const;  size_t HeightMap() const;  size_t OccupancyGrid() const;
//   };
//
// Run*<Adapter> are the loops; bench_register.h registers them as BM_<Operation>_Name/<arg>
// benchmarks (insert args are the resolution in mm; radius args the radius in cm; box
// args the box side in cm). Structures used by queries are built once per process on first
// use and cached, together with the heap bytes their build allocated (HeapBytesInUse()).
//
// Every answer is checked, and a structure that disagrees fails its benchmark with
// SkipWithError (the report then refuses to write the docs): after an insert benchmark the
// structure must hold exactly the voxel set of the frames it was given (same count, every
// key present); every radius query must return exactly ExactRadiusHits (bench_workloads.h),
// for all 1 024 queries once before timing and for each timed query.
//
// Thread safety: Google Benchmark runs these on its main thread only.
#ifndef SKIMAP_BENCH_BENCH_HARNESS_H_
#define SKIMAP_BENCH_BENCH_HARNESS_H_

#include <benchmark/benchmark.h>

#include <cstdio>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "bench/bench_data.h"
#include "bench/bench_workloads.h"

namespace skimap::bench {

// Point indexes (kd-tree, PCL octree) are built from voxel centres, so that they answer
// exactly the question the voxel maps answer.
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
    if (w != Workload::kBig) clouds = {&VoxelCenters(w, res_mm)};
  }
  Built<S> b;
  const size_t before = HeapBytesInUse();
  b.s = std::make_unique<S>(res_mm * 1e-3);
  for (const Cloud* c : clouds) b.s->Insert(*c);
  b.s->ReleaseScratch();
  b.heap_bytes = HeapBytesInUse() - before;
  return cache.emplace(std::pair{w, res_mm}, std::move(b)).first->second;
}

// Fails the benchmark loudly (SkipWithError + stderr) and returns false.
bool Fail(benchmark::State& state, const std::string& what);

// Checks that s holds exactly the voxels `want` (count and membership).
template <class S>
bool CheckVoxelSet(benchmark::State& state, const S& s, const std::vector<VoxelKey>& want) {
  size_t missing = 0;
  for (const VoxelKey& k : want) missing += !s.HasVoxel(k);
  if (missing == 0 && s.Voxels() == want.size()) return true;
  return Fail(state, "voxel set differs from the frames': " + std::to_string(s.Voxels()) +
                         " voxels, want " + std::to_string(want.size()) + ", " +
                         std::to_string(missing) + " missing");
}

std::vector<VoxelKey> KeysOf(const VoxelBatch<WeightVoxel>& batch);

// Inserts one frame per iteration (cycling through `frames`), into an empty structure
// (steady = false; the reset is not timed) or into one that already holds every frame.
// merged = false: the whole pipeline (points -> structure, S::Insert); merged = true: the
// structure only (the frame's finalized MergedBatch -> structure, S::InsertMerged; the
// merge is done before timing). Then checks the voxel set.
template <class S>
void RunInsert(benchmark::State& state, const std::vector<Cloud>& frames, bool steady,
               bool merged) {
  if (frames.empty()) {
    state.SkipWithError(("no frames: " + YcbvError()).c_str());
    return;
  }
  const int res_mm = static_cast<int>(state.range(0));
  std::vector<const VoxelBatch<WeightVoxel>*> batches;
  size_t distinct = 0;
  for (const Cloud& f : frames) {
    batches.push_back(&MergedBatch(f, res_mm));
    distinct += batches.back()->size();
  }
  std::unique_ptr<S> s;
  auto insert = [&](size_t f) {
    if constexpr (requires { s->InsertMerged(*batches[f]); }) {
      if (merged) return s->InsertMerged(*batches[f]);
    }
    s->Insert(frames[f]);
  };
  auto reset = [&] {
    if constexpr (requires { s->Reset(); }) {
      if (s != nullptr) {
        s->Reset();  // keeps the structure's reusable scratch, as a live map worker would
      } else {
        s = std::make_unique<S>(res_mm * 1e-3);
      }
    } else {
      s.reset();
      s = std::make_unique<S>(res_mm * 1e-3);
    }
    if (steady) {
      for (size_t f = 0; f < frames.size(); ++f) insert(f);
    }
  };
  reset();
  size_t i = 0, points = 0;
  for (auto _ : state) {
    const size_t f = i++ % frames.size();
    if (!steady) {
      state.PauseTiming();
      reset();
      state.ResumeTiming();
    }
    insert(f);
    points += frames[f].size();
  }
  const double iters = static_cast<double>(state.iterations());
  state.SetItemsProcessed(static_cast<int64_t>(points));
  state.counters["points"] = static_cast<double>(points) / iters;
  // Distinct voxels per frame (mean over the frames): the merged rows' unit of work.
  state.counters["distinct"] = static_cast<double>(distinct) / static_cast<double>(frames.size());
  state.counters["voxels"] = static_cast<double>(s->Voxels());
  CheckVoxelSet(state, *s,
                steady ? UnionKeys(frames, res_mm) : KeysOf(*batches[(i - 1) % frames.size()]));
}

// Checks s against ExactRadiusHits for every query (once per structure, workload and
// radius), then times the queries in turn, checking each answer too.
template <class S>
void RunRadius(benchmark::State& state, Workload w) {
  const S& s = *Cached<S>(w, w == Workload::kUniform ? kUniformResMm : kSurfaceResMm).s;
  const Cloud& queries = QueryCentersFor(w);
  const int r_cm = static_cast<int>(state.range(0));
  const double r = r_cm * 1e-2;
  const std::vector<uint32_t>& want = ExactRadiusHits(w, r_cm);
  static std::set<std::pair<Workload, int>> verified;
  if (verified.insert({w, r_cm}).second) {
    for (size_t q = 0; q < queries.size(); ++q) {
      const size_t got = s.RadiusSearch(queries[q], r);
      if (got != want[q]) {
        verified.erase({w, r_cm});
        Fail(state, "query " + std::to_string(q) + ": " + std::to_string(got) + " hits, want " +
                        std::to_string(want[q]));
        return;
      }
    }
  }
  size_t i = 0, hits = 0, wrong = 0;
  for (auto _ : state) {
    const size_t q = i++ % queries.size();
    const size_t n = s.RadiusSearch(queries[q], r);
    hits += n;
    wrong += n != want[q];
  }
  state.counters["hits"] = static_cast<double>(hits) / static_cast<double>(state.iterations());
  if (wrong > 0) Fail(state, std::to_string(wrong) + " timed queries with a wrong hit count");
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
