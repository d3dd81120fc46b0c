#include "bench/bench_harness.h"

namespace skimap::bench {

bool Fail(benchmark::State& state, const std::string& what) {
  // The benchmark's name is in its JSON entry (error_message); State has no accessor.
  std::fprintf(stderr, "BENCHMARK CHECK FAILED: %s\n", what.c_str());
  state.SkipWithError(what.c_str());
  return false;
}

std::vector<VoxelKey> KeysOf(const VoxelBatch<WeightVoxel>& batch) {
  std::vector<VoxelKey> keys;
  keys.reserve(batch.size());
  for (const auto& item : batch.items()) keys.push_back(item.key);
  return keys;
}

}  // namespace skimap::bench
