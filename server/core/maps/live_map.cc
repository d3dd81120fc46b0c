#include "server/core/maps/live_map.h"

#include <cstdio>
#include <limits>
#include <map>
#include <random>
#include <type_traits>
#include <utility>

#include "absl/strings/str_cat.h"
#include "perception/frame_integrator.h"
#include "server/core/logging/log.h"
#include "server/core/maps/free_space_grid.h"
#include "server/core/transfer/chunk_codec.h"
#include "server/core/transfer/map_meta.h"

namespace skimap::server {

LiveMap::LiveMap(std::string id, const Options& options)
    : id_(std::move(id)),
      incarnation_(uint64_t{std::random_device()()} << 32 | std::random_device()()),
      options_(options),
      state_(options.config, options.pool),
      stages_(MakeFrameStages(options.config, Grid(options.config.resolution), options.pool)),
      queue_({.capacity = options.queue_capacity, .nice = options.worker_nice}) {
  recognition_ = std::make_unique<MapRecognition>(
      MapRecognition::Options{.map_id = id_,
                              .config = &options_.config,
                              .worker_nice = options_.worker_nice,
                              .classifier = options_.classifier,
                              .metrics = options_.metrics},
      MapRecognition::Map{.mu = &snapshot_mu_,
                          .state = &state_,
                          .index = &index_,
                          .worker = &queue_,
                          .refused = [this] { return Refused(); },
                          .instances_changed = [this] { NotifyWatchers(); },
                          .changes = &recognition_changes_});
}

LiveMap::~LiveMap() {
  // Queued writes run first (they may hand frames to recognition), then recognition stops
  // (its last job may still use the worker), then the worker goes.
  Drain();
  recognition_->Stop();
}

absl::Status LiveMap::Refused() const {
  if (deleted_.load(std::memory_order_acquire)) {
    return absl::NotFoundError(absl::StrCat("map ", MapName(id_), " was deleted"));
  }
  if (evicted_.load(std::memory_order_acquire)) {
    return absl::UnavailableError(
        absl::StrCat("map ", MapName(id_), " was unloaded from memory meanwhile; retry"));
  }
  return absl::OkStatus();
}

std::string LiveMap::RetentionPolicy() const {
  return absl::StrCat(
      "retention policy: once snapshotted, the oldest frame records are pruned "
      "while the map's frame records exceed ",
      options_.journal_retain_bytes, " bytes (skimapd --journal_retain_mb)");
}

v1::MapStats LiveMap::Stats() const {
  v1::MapStats stats;
  ReaderLock lock(&snapshot_mu_);
  stats.set_voxels(state_.rgb.size());
  size_t memory = 0;
  state_.ForEachVolume(
      [&](const char*, const auto& volume, const DirtyChunks&) { memory += volume.MemoryUsage(); });
  stats.set_memory_bytes(memory);
  stats.set_recognized_frames(state_.recognition.recognized_frames);
  stats.set_recognition_skipped(recognition_->skipped());
  stats.set_label_voxels(state_.labels.size());
  stats.set_hypothesis_voxels(state_.hypotheses.size());
  stats.set_instances(state_.recognition.instance_keys.size());
  stats.set_instance_event_sequence(state_.recognition.log.last_sequence());
  stats.set_frames(state_.frames);
  stats.set_kept_frame_bytes(kept_frame_bytes_.load(std::memory_order_relaxed));
  stats.set_free_voxels(CountFreeColumns(state_.free));
  stats.set_journal_position(journal_position_.load(std::memory_order_acquire));
  stats.set_persistent(options_.store != nullptr);
  stats.set_snapshot_position(snapshot_position_.load(std::memory_order_acquire));
  if (const int64_t ms = snapshot_unix_ms_.load(std::memory_order_acquire); ms > 0) {
    stats.mutable_snapshot_time()->set_seconds(ms / 1000);
    stats.mutable_snapshot_time()->set_nanos(static_cast<int32_t>(ms % 1000) * 1000000);
  }
  stats.set_pruned_position(pruned_position_.load(std::memory_order_acquire));
  stats.set_journal_bytes(journal_bytes_.load(std::memory_order_relaxed));
  stats.set_loaded(true);
  if (std::optional<KeyBox> box = state_.rgb.Bounds()) {
    const Grid& g = state_.rgb.grid();
    const double r = g.resolution();
    auto* b = stats.mutable_bounds();
    b->mutable_min()->set_x(g.origin().x + box->min.x * r);
    b->mutable_min()->set_y(g.origin().y + box->min.y * r);
    b->mutable_min()->set_z(g.origin().z + box->min.z * r);
    b->mutable_max()->set_x(g.origin().x + (box->max.x + 1) * r);
    b->mutable_max()->set_y(g.origin().y + (box->max.y + 1) * r);
    b->mutable_max()->set_z(g.origin().z + (box->max.z + 1) * r);
  }
  return stats;
}

uint64_t LiveMap::AddInstanceWatcher(std::function<void()> wake) {
  std::lock_guard<std::mutex> lock(watchers_mu_);
  const uint64_t id = next_watcher_++;
  watchers_[id] = std::move(wake);
  return id;
}

void LiveMap::RemoveInstanceWatcher(uint64_t id) {
  std::lock_guard<std::mutex> lock(watchers_mu_);
  watchers_.erase(id);
}

uint64_t LiveMap::AddChangeWatcher(std::function<void()> wake) {
  std::lock_guard<std::mutex> lock(watchers_mu_);
  const uint64_t id = next_watcher_++;
  change_watchers_[id] = std::move(wake);
  return id;
}

void LiveMap::RemoveChangeWatcher(uint64_t id) {
  std::lock_guard<std::mutex> lock(watchers_mu_);
  change_watchers_.erase(id);
}

void LiveMap::NotifyChangeWatchers() {
  std::lock_guard<std::mutex> lock(watchers_mu_);
  for (auto& [id, wake] : change_watchers_) wake();
}

void LiveMap::NotifyWatchers() {
  std::lock_guard<std::mutex> lock(watchers_mu_);
  for (auto& [id, wake] : watchers_) wake();
}

}  // namespace skimap::server
