// Registration of the shared benchmark loops (bench_harness.h) for one structure adapter:
//
//   RegisterInserts<MyAdapter>("Mine");        // BM_InsertRoom_Mine/10,
//   BM_InsertYcbvSteady_Mine/50 RegisterMergedInserts<MyAdapter>("Mine");  //
//   BM_InsertRoomMerged_Mine/10, ... RegisterRadius<MyAdapter>("Mine");         //
//   BM_RadiusUniform_Mine/5, BM_RadiusSurface_Mine/100 RegisterMapQueries<MyAdapter>("Mine"); //
//   box, visit-all, height map, occupancy grid RegisterMemory<MyAdapter>("Mine");         //
//   BM_MemoryBig_Mine/10, BM_MemorySurface_Mine/20
//
// Call them from a static initializer in the adapter's .cc file, before main runs.
#ifndef SKIMAP_BENCH_BENCH_REGISTER_H_
#define SKIMAP_BENCH_BENCH_REGISTER_H_

#include <string>
#include <vector>

#include "bench/bench_harness.h"

namespace skimap::bench {

template <class S>
void RegisterInsertOps(const std::string& name, const std::vector<int64_t>& res_mm, bool merged) {
  auto reg = [&](const std::string& wl, bool steady, bool real) {
    const std::string op = "Insert" + wl + (merged ? "Merged" : "") + (steady ? "Steady" : "");
    auto* b = benchmark::RegisterBenchmark(
        ("BM_" + op + "_" + name).c_str(), [steady, real, merged](benchmark::State& st) {
          RunInsert<S>(st, real ? YcbvFrames() : RoomFrameList(), steady, merged);
        });
    for (int64_t r : res_mm) b->Arg(r);
    b->Unit(benchmark::kMillisecond)->UseRealTime();
  };
  reg("Room", false, false);
  reg("Room", true, false);
  reg("Ycbv", false, true);
  reg("Ycbv", true, true);
}

// Room frame at 1, 2, 5 cm and the real frames, empty and steady state. Whole pipeline
// (points -> structure, S::Insert): BM_InsertRoom_<name>, BM_InsertYcbvSteady_<name>, ...
template <class S>
void RegisterInserts(const std::string& name, std::vector<int64_t> res_mm = {10, 20, 50}) {
  RegisterInsertOps<S>(name, res_mm, /*merged=*/false);
}

// The same frames as finalized merged batches (structure only, S::InsertMerged):
// BM_InsertRoomMerged_<name>, BM_InsertYcbvMergedSteady_<name>, ...
template <class S>
void RegisterMergedInserts(const std::string& name, std::vector<int64_t> res_mm = {10, 20, 50}) {
  static_assert(
      requires(S & s, const VoxelBatch<WeightVoxel>& b) { s.InsertMerged(b); },
      "RegisterMergedInserts needs S::InsertMerged(const VoxelBatch<WeightVoxel>&)");
  RegisterInsertOps<S>(name, res_mm, /*merged=*/true);
}

template <class S>
void RegisterRadius(const std::string& name) {
  benchmark::RegisterBenchmark(("BM_RadiusUniform_" + name).c_str(),
                               [](benchmark::State& st) { RunRadius<S>(st, Workload::kUniform); })
      ->Arg(5)
      ->Arg(20)
      ->Arg(50)
      ->Unit(benchmark::kMicrosecond);
  benchmark::RegisterBenchmark(("BM_RadiusSurface_" + name).c_str(),
                               [](benchmark::State& st) { RunRadius<S>(st, Workload::kSurface); })
      ->Arg(2)
      ->Arg(10)
      ->Arg(20)
      ->Arg(50)
      ->Arg(100)
      ->Unit(benchmark::kMicrosecond);
}

// Box, visit-all, height map and occupancy grid on the big map, where S supports them.
template <class S>
void RegisterMapQueries(const std::string& name) {
  auto tail = [](benchmark::internal::Benchmark* b) { b->Unit(benchmark::kMillisecond); };
  if constexpr (requires(const S& s, PointF p) { s.BoxCount(p, p); }) {
    benchmark::RegisterBenchmark(("BM_BoxQuery_" + name).c_str(), RunBox<S>)
        ->Arg(50)
        ->Arg(200)
        ->Unit(benchmark::kMicrosecond);
  }
  if constexpr (requires(const S& s) { s.VisitAll(); }) {
    tail(benchmark::RegisterBenchmark(("BM_VisitAll_" + name).c_str(), [](benchmark::State& st) {
      RunWhole<S>(st, [](const S& s) { return s.VisitAll(); });
    }));
  }
  if constexpr (requires(const S& s) { s.HeightMap(); }) {
    tail(benchmark::RegisterBenchmark(("BM_HeightMap_" + name).c_str(), [](benchmark::State& st) {
      RunWhole<S>(st, [](const S& s) { return s.HeightMap(); });
    }));
  }
  if constexpr (requires(const S& s) { s.OccupancyGrid(); }) {
    tail(benchmark::RegisterBenchmark(
        ("BM_OccupancyGrid_" + name).c_str(), [](benchmark::State& st) {
          RunWhole<S>(st, [](const S& s) { return s.OccupancyGrid(); });
        }));
  }
}

// Heap bytes per voxel on the big map, the surface maps at 1, 2, 5 cm and the uniform points.
template <class S>
void RegisterMemory(const std::string& name, bool big = true) {
  auto reg = [&](Workload w, std::vector<int64_t> res) {
    auto* b = benchmark::RegisterBenchmark(
        (std::string("BM_Memory") + WorkloadName(w) + "_" + name).c_str(),
        [w](benchmark::State& st) { RunMemory<S>(st, w); });
    for (int64_t r : res) b->Arg(r);
    b->Iterations(1);
  };
  reg(Workload::kUniform, {kUniformResMm});
  reg(Workload::kSurface, {10, 20, 50});
  if (big) reg(Workload::kBig, {kBigResMm});
}

}  // namespace skimap::bench

#endif  // SKIMAP_BENCH_BENCH_REGISTER_H_
