#include "server/core/maps/frame_stages.h"

#include <utility>

#include "perception/free_space.h"

namespace skimap::server {
namespace {

// Staged additions and removals of one volume of voxel type V. A frame is built into
// `scratch_`; a lone addition is built straight into `add_`, anything more is merged item
// by item. Seal() copies the open additions' items into the sealed frames (their batches
// reused across Applies), each applied on its own: only `add_` and `scratch_` carry a
// whole image's room and sort scratch (about 20 MB a 640x480 frame), a sealed frame its
// merged items (a tenth of that), so a group of frames touches little new memory (page
// faults cost this project's VM more than the copy).
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
  void Seal() {
    if (sealed_count_ == sealed_.size()) sealed_.emplace_back();
    sealed_[sealed_count_++].CopyItemsFrom(add_);
    add_.Clear();
  }
  WriteStats Apply(SkiMap<V>* volume, DirtyChunks* dirty, ThreadPool* pool,
                   std::vector<WriteStats>* per_sealed) {
    WriteStats stats;
    if (!remove_.empty()) {
      remove_.Finalize(pool);
      MarkDirtyChunks(remove_.items(), dirty);
      stats += volume->Deintegrate(remove_);
    }
    if (per_sealed != nullptr && per_sealed->size() < sealed_count_) {
      per_sealed->resize(sealed_count_);
    }
    for (size_t i = 0; i < sealed_count_; ++i) {
      const WriteStats frame = IntegrateBatch(sealed_[i], volume, dirty, pool);
      stats += frame;
      if (per_sealed != nullptr) (*per_sealed)[i] += frame;
    }
    stats += IntegrateBatch(add_, volume, dirty, pool);
    Clear();
    return stats;
  }
  void Clear() {
    add_.Clear();
    remove_.Clear();
    for (size_t i = 0; i < sealed_count_; ++i) sealed_[i].Clear();
    sealed_count_ = 0;
  }

 private:
  static WriteStats IntegrateBatch(VoxelBatch<V>& batch, SkiMap<V>* volume, DirtyChunks* dirty,
                                   ThreadPool* pool) {
    if (batch.empty()) return {};
    batch.Finalize(pool);
    MarkDirtyChunks(batch.items(), dirty);
    return volume->Integrate(batch);
  }

  VoxelBatch<V> add_, remove_, scratch_;
  std::vector<VoxelBatch<V>> sealed_;  // the first sealed_count_ hold sealed frames
  size_t sealed_count_ = 0;
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
  void Seal() override { pending_.Seal(); }
  WriteStats Apply(MapState* state, std::vector<WriteStats>* per_sealed) override {
    return pending_.Apply(&state->rgb, &state->dirty_rgb, pool_, per_sealed);
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
    pending_.Stage(sign, [&](VoxelBatch<FreeColumnsVoxel>* batch) {
      perception::BuildFreeSpaceBatch(frame, grid_, integration_, free_space_, batch, pool_);
    });
    return {};
  }
  void Seal() override { pending_.Seal(); }
  WriteStats Apply(MapState* state, std::vector<WriteStats>* per_sealed) override {
    return pending_.Apply(&state->free, &state->dirty_free, pool_, per_sealed);
  }
  void Clear() override { pending_.Clear(); }

 private:
  const perception::IntegrationOptions integration_;
  const perception::FreeSpaceOptions free_space_;
  const Grid grid_;
  ThreadPool* const pool_;
  Pending<FreeColumnsVoxel> pending_;
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
