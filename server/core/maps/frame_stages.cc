#include "server/core/maps/frame_stages.h"

#include "perception/free_space.h"

namespace skimap::server {
namespace {

// Staged additions and removals of one volume of voxel type V. A frame is built into
// `scratch_`; a lone addition is built straight into `add_` (the ingestion hot path copies
// nothing), anything more is merged item by item.
template <Voxel V>
class Pending {
 public:
  template <class Build>
  void Stage(FrameStage::Sign sign, Build&& build) {
    VoxelBatch<V>& target = sign == FrameStage::kAdd ? add_ : remove_;
    if (target.empty()) {
      build(&target);
      return;
    }
    build(&scratch_);
    target.AddItems(scratch_.items());
  }
  WriteStats Apply(SkiMap<V>* volume, DirtyChunks* dirty, ThreadPool* pool) {
    remove_.Finalize(pool);
    add_.Finalize(pool);
    MarkDirtyChunks(remove_.items(), dirty);
    MarkDirtyChunks(add_.items(), dirty);
    WriteStats stats;
    if (!remove_.empty()) stats += volume->Deintegrate(remove_);
    if (!add_.empty()) stats += volume->Integrate(add_);
    Clear();
    return stats;
  }
  void Clear() {
    add_.Clear();
    remove_.Clear();
  }

 private:
  VoxelBatch<V> add_, remove_, scratch_;
};

class IntegrateStage final : public FrameStage {
 public:
  IntegrateStage(const MapConfig& config, const Grid& grid, ThreadPool* pool)
      : options_(config.integration), grid_(grid), pool_(pool) {}
  perception::IntegrationStats Stage(const perception::RgbdFrame& frame, Sign sign) override {
    perception::IntegrationStats stats;
    pending_.Stage(sign, [&](VoxelBatch<RGBWeightedVoxel>* batch) {
      stats = perception::BuildFrameBatch(frame, grid_, options_, batch, pool_);
    });
    return stats;
  }
  WriteStats Apply(MapState* state) override {
    return pending_.Apply(&state->rgb, &state->dirty_rgb, pool_);
  }
  void Clear() override { pending_.Clear(); }

 private:
  const perception::IntegrationOptions options_;
  const Grid grid_;
  ThreadPool* const pool_;
  Pending<RGBWeightedVoxel> pending_;
};

class CarveStage final : public FrameStage {
 public:
  CarveStage(const MapConfig& config, const Grid& grid, ThreadPool* pool)
      : integration_(config.integration),
        free_space_(config.FreeSpace()),
        grid_(grid),
        pool_(pool) {}
  perception::IntegrationStats Stage(const perception::RgbdFrame& frame, Sign sign) override {
    pending_.Stage(sign, [&](VoxelBatch<WeightVoxel>* batch) {
      perception::BuildFreeSpaceBatch(frame, grid_, integration_, free_space_, batch, pool_);
    });
    return {};
  }
  WriteStats Apply(MapState* state) override {
    return pending_.Apply(&state->free, &state->dirty_free, pool_);
  }
  void Clear() override { pending_.Clear(); }

 private:
  const perception::IntegrationOptions integration_;
  const perception::FreeSpaceOptions free_space_;
  const Grid grid_;
  ThreadPool* const pool_;
  Pending<WeightVoxel> pending_;
};

}  // namespace

std::vector<std::unique_ptr<FrameStage>> MakeFrameStages(const MapConfig& config, const Grid& grid,
                                                         ThreadPool* pool) {
  std::vector<std::unique_ptr<FrameStage>> stages;
  stages.push_back(std::make_unique<IntegrateStage>(config, grid, pool));
  if (config.carve_free_space) stages.push_back(std::make_unique<CarveStage>(config, grid, pool));
  return stages;
}

}  // namespace skimap::server
