// LiveMap's persistence: loading a map (its snapshot chunks, then the journal after them),
// replaying journal records, reading a journaled frame back (pose updates re-integrate it),
// and snapshots (captured on the worker, encoded and written off it). The write path and
// the queries are live_map.cc, pose updates live_map_poses.cc; the contract is live_map.h.
#include <chrono>
#include <limits>
#include <utility>

#include "absl/strings/str_cat.h"
#include "server/core/logging/log.h"
#include "server/core/maps/frame_decode.h"
#include "server/core/maps/live_map.h"
#include "server/core/transfer/chunk_codec.h"
#include "server/core/transfer/map_meta.h"

namespace skimap::server {
// What a snapshot writes, copied on the worker: the journal position it covers, an
// encoder per changed chunk (run off the worker), the chunks left empty, the frame-index
// chunks, and the retention cut to prune after it is durable.
struct LiveMap::Capture {
  uint64_t position = 0;
  std::vector<std::function<storage::Chunk()>> encoders;
  std::vector<storage::ChunkKey> removed;
  std::vector<storage::Chunk> index_chunks;
  std::vector<std::pair<std::string, ChunkCoord>> coords;  // every captured volume chunk
  std::vector<int64_t> buckets;                            // every captured index chunk
  bool meta = false;                                       // the meta chunk was captured
  uint64_t prune_upto = 0;
  bool empty() const { return encoders.empty() && removed.empty() && index_chunks.empty(); }
};

namespace {

// Tells clang's thread-safety analysis that `mu` is held exclusively, in callbacks that run
// under it; checks nothing at run time.
void AssumeHeld(const RwLock& mu) ABSL_ASSERT_EXCLUSIVE_LOCK(mu) {}

constexpr char kFramesVolume[] = "frames";  // chunk volume name of the frame index
constexpr size_t kReplayBatch = 64;         // journal records read per store call

int64_t NowUnixMs() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

// Chunk coordinates read back from a store fit the key range (they were written by
// ChunkOf); anything else is corruption.
bool ValidChunkCoord(const storage::ChunkKey& k) {
  constexpr int64_t kMin = std::numeric_limits<int32_t>::min() >> kChunkShift;
  constexpr int64_t kMax = std::numeric_limits<int32_t>::max() >> kChunkShift;
  return k.x >= kMin && k.x <= kMax && k.y >= kMin && k.y <= kMax && k.z >= kMin && k.z <= kMax;
}

}  // namespace

absl::Status LiveMap::Load() {
  absl::Status loaded = queue_.Run([this] { return LoadSnapshotOnWorker(); });
  if (!loaded.ok()) return loaded;
  // The journal after the snapshot, in batches: replay reads the store again (pose
  // updates read their frames back), which ReadJournal's callback must not.
  uint64_t after = snapshot_position_.load(std::memory_order_acquire);
  for (;;) {
    std::vector<storage::JournalRecord> batch;
    absl::Status read =
        options_.store->ReadJournal(id_, after, kReplayBatch, [&](const storage::JournalRecord& r) {
          batch.push_back(r);
          return absl::OkStatus();
        });
    if (!read.ok()) return read;
    if (batch.empty()) return absl::OkStatus();
    for (const storage::JournalRecord& r : batch) {
      absl::Status s = queue_.Run([&] { return ReplayOnWorker(r); });
      if (absl::IsDataLoss(s)) return s;
      if (!s.ok()) {
        LogWarning(absl::StrCat("map ", MapName(id_), ": journal record ", r.position,
                                " skipped: ", s.ToString()));
      }
      after = r.position;
    }
  }
}

absl::Status LiveMap::LoadSnapshotOnWorker() {
  storage::MapStore& store = *options_.store;
  absl::StatusOr<storage::StoredMap> stored = store.GetMap(id_);
  if (!stored.ok()) return stored.status();
  auto chunk_error = [&](const storage::ChunkKey& k, const absl::Status& s) {
    return absl::Status(s.code(), absl::StrCat("snapshot of ", MapName(id_), ": chunk ", k.volume,
                                               " (", k.x, ",", k.y, ",", k.z, "): ", s.message()));
  };
  absl::StatusOr<uint64_t> covered;
  {
    WriterLock lock(&snapshot_mu_);
    covered = store.ReadSnapshot(id_, [&](const storage::Chunk& c) -> absl::Status {
      AssumeHeld(snapshot_mu_);  // ReadSnapshot calls back here, under the lock above
      if (c.key.volume == kFramesVolume) {
        absl::Status s = index_.DecodeBucket(c.key.x, c.bytes);
        return s.ok() ? s : chunk_error(c.key, s);
      }
      if (c.key.volume == kMetaVolume) {
        absl::StatusOr<MapMeta> meta = DecodeMapMeta(c.bytes);
        if (!meta.ok()) return chunk_error(c.key, meta.status());
        state_.recognition.next_instance_id = meta->next_instance_id;
        state_.recognition.log.Restart(meta->last_event_sequence);
        state_.recognition.fingerprint = meta->fingerprint;
        return absl::OkStatus();
      }
      if (!ValidChunkCoord(c.key)) {
        return chunk_error(c.key, absl::DataLossError("coordinates outside the key range"));
      }
      const ChunkCoord coord{int32_t(c.key.x), int32_t(c.key.y), int32_t(c.key.z)};
      absl::Status s = absl::FailedPreconditionError("unknown volume (written by a newer server?)");
      state_.ForEachVolume([&](const char* name, auto& volume, DirtyChunks&) {
        if (c.key.volume != name) return;
        using V = typename std::remove_reference_t<decltype(volume)>::VoxelType;
        VoxelBatch<V> batch;
        s = DecodeVoxelChunk<V>(coord, c.bytes, &batch);
        if (!s.ok()) return;
        batch.Finalize();  // sorted and unique already; marks the batch ready
        volume.Integrate(batch);
      });
      return s.ok() ? s : chunk_error(c.key, s);
    });
    if (!covered.ok()) return covered.status();
    state_.frames = index_.size();
    state_.journal_position = *covered;
    state_.ForEachVolume([](const char*, auto&, DirtyChunks& dirty) { dirty.clear(); });
  }
  (void)index_.TakeDirty();
  recognition_->AfterLoad();
  // Records before the first one left in the journal were pruned.
  uint64_t first = 0;
  absl::Status read = store.ReadJournal(id_, 0, 1, [&](const storage::JournalRecord& r) {
    first = r.position;
    return absl::OkStatus();
  });
  if (!read.ok()) return read;
  const uint64_t pruned = first > 0 ? first - 1 : stored->last_position;
  index_.MarkPruned(pruned);
  pruned_position_.store(pruned, std::memory_order_release);
  journal_bytes_.store(index_.journal_bytes(), std::memory_order_release);
  journal_position_.store(std::max(*covered, pruned), std::memory_order_release);
  snapshot_position_.store(*covered, std::memory_order_release);
  snapshot_unix_ms_.store(stored->snapshot_unix_ms, std::memory_order_release);
  return absl::OkStatus();
}

absl::Status LiveMap::ReplayOnWorker(const storage::JournalRecord& record) {
  journal_position_.store(record.position, std::memory_order_release);
  if (record.kind == storage::JournalRecord::kFrame) {
    auto frame = std::make_shared<v1::Frame>();
    if (!frame->ParseFromString(record.payload)) {
      return absl::DataLossError(
          absl::StrCat("journal: ", MapName(id_), ": record ", record.position, " is not a Frame"));
    }
    return IntegrateOnWorker(frame, Source::kReplay, record.position).status();
  }
  v1::UpdatePosesRequest request;
  if (!request.ParseFromString(record.payload)) {
    return absl::DataLossError(absl::StrCat("journal: ", MapName(id_), ": record ", record.position,
                                            " is not an UpdatePosesRequest"));
  }
  return UpdatePosesOnWorker(request, Source::kReplay, record.position).status();
}

absl::StatusOr<std::shared_ptr<const v1::Frame>> LiveMap::FrameOf(const FrameIndex::Entry& entry,
                                                                  uint64_t sequence,
                                                                  const std::string& field) {
  if (options_.store == nullptr) {
    if (entry.frame != nullptr) return entry.frame;
    return absl::FailedPreconditionError(absl::StrCat(
        field, ".sequence: frame ", sequence, " is no longer kept in memory (the newest ",
        options_.max_kept_frame_bytes, " bytes of frames are; this server has no data dir)"));
  }
  const auto pruned = [&] {
    return absl::FailedPreconditionError(
        absl::StrCat(field, ".sequence: frame ", sequence,
                     " is no longer in the journal: pruned by the ", RetentionPolicy(),
                     ", or left out of an export made without its journal (skimap export "
                     "--with-journal keeps it)"));
  };
  if (index_.Pruned(entry)) return pruned();
  absl::StatusOr<storage::JournalRecord> record =
      options_.store->ReadJournalRecord(id_, entry.position);
  if (absl::IsNotFound(record.status())) return pruned();
  if (!record.ok()) {
    return absl::Status(record.status().code(),
                        absl::StrCat("journal: ", MapName(id_), ": ", record.status().message()));
  }
  auto frame = std::make_shared<v1::Frame>();
  if (record->kind != storage::JournalRecord::kFrame || !frame->ParseFromString(record->payload)) {
    return absl::DataLossError(absl::StrCat("journal: ", MapName(id_), ": record ", entry.position,
                                            " is not frame ", sequence));
  }
  return frame;
}

std::unique_ptr<LiveMap::Capture> LiveMap::CaptureOnWorker() {
  auto c = std::make_unique<Capture>();
  index_.MarkPruned(pruned_position_.load(std::memory_order_acquire));
  // The dirty sets are taken under the exclusive lock (a moment); the chunks are copied
  // under the shared one, so queries go on meanwhile. Nothing changes in between: this is
  // the worker, the map's only writer.
  std::map<std::string, DirtyChunks> taken;
  {
    WriterLock lock(&snapshot_mu_);
    c->position = state_.journal_position;
    state_.ForEachVolume([&](const char* name, auto&, DirtyChunks& dirty) {
      taken[name] = std::move(dirty);
      dirty.clear();
    });
    recognition_changes_.store(0, std::memory_order_release);
    if (state_.recognition.meta_dirty) {
      state_.recognition.meta_dirty = false;
      c->meta = true;
      c->index_chunks.push_back(
          {{kMetaVolume, 0, 0, 0},
           EncodeMapMeta({.next_instance_id = state_.recognition.next_instance_id,
                          .last_event_sequence = state_.recognition.log.last_sequence(),
                          .fingerprint = state_.recognition.fingerprint})});
    }
  }
  ReaderLock lock(&snapshot_mu_);
  state_.ForEachVolume([&](const char* name, const auto& volume, const DirtyChunks&) {
    using V = typename std::remove_cvref_t<decltype(volume)>::VoxelType;
    for (const ChunkCoord& coord : taken[name]) {
      c->coords.emplace_back(name, coord);
      std::vector<typename VoxelBatch<V>::Item> items;
      volume.ForEachInBox(ChunkBox(coord), [&](const VoxelKey& k, const V& v) {
        items.push_back({k, v});
      });
      storage::ChunkKey key{name, coord.x, coord.y, coord.z};
      if (items.empty()) {
        c->removed.push_back(std::move(key));
        continue;
      }
      c->encoders.push_back([key = std::move(key), coord, items = std::move(items)] {
        return storage::Chunk{key, EncodeVoxelChunk<V>(coord, items)};
      });
    }
  });
  c->buckets = index_.TakeDirty();
  for (int64_t b : c->buckets) {
    storage::Chunk chunk;
    chunk.key.volume = kFramesVolume;
    chunk.key.x = b;
    chunk.bytes = index_.EncodeBucket(b);
    c->index_chunks.push_back(std::move(chunk));
  }
  c->prune_upto = index_.RetentionCut(c->position, options_.journal_retain_bytes);
  return c;
}

absl::Status LiveMap::Snapshot() {
  if (options_.store == nullptr) return absl::OkStatus();
  std::lock_guard<std::mutex> one_at_a_time(snapshot_run_mu_);
  if (snapshot_holds_.load(std::memory_order_acquire) > 0) return absl::OkStatus();
  return SnapshotLocked();
}

absl::StatusOr<LiveMap::SnapshotHold> LiveMap::SnapshotAndHold() {
  if (options_.store == nullptr) {
    return absl::FailedPreconditionError(
        absl::StrCat("map ", MapName(id_), " is in memory only (no store)"));
  }
  std::lock_guard<std::mutex> one_at_a_time(snapshot_run_mu_);
  if (absl::Status s = SnapshotLocked(); !s.ok()) return s;
  snapshot_holds_.fetch_add(1, std::memory_order_acq_rel);
  return SnapshotHold(this);
}

absl::Status LiveMap::SnapshotLocked() {
  std::unique_ptr<Capture> c = queue_.Run([this] { return CaptureOnWorker(); });
  const uint64_t pruned = pruned_position_.load(std::memory_order_acquire);
  if (c->empty() && c->position == snapshot_position_.load(std::memory_order_acquire) &&
      c->prune_upto <= pruned) {
    return absl::OkStatus();
  }
  std::vector<storage::Chunk> chunks = std::move(c->index_chunks);
  chunks.reserve(chunks.size() + c->encoders.size());
  for (const auto& encode : c->encoders) chunks.push_back(encode());
  absl::Status written = options_.store->WriteSnapshot(id_, c->position, chunks, c->removed);
  if (!written.ok()) {
    // Pending again: the next snapshot writes these chunks (with their newer content).
    {
      WriterLock lock(&snapshot_mu_);
      for (const auto& entry : c->coords) {  // (volume, chunk); clang 14 cannot capture bindings
        state_.ForEachVolume([&](const char* n, auto&, DirtyChunks& dirty) {
          if (entry.first == n) dirty.insert(entry.second);
        });
      }
      if (c->meta) state_.recognition.meta_dirty = true;
    }
    recognition_changes_.fetch_add(1, std::memory_order_acq_rel);
    (void)queue_.Submit([this, buckets = std::move(c->buckets)] { index_.MarkDirty(buckets); });
    return absl::Status(written.code(), absl::StrCat("snapshot of ", MapName(id_),
                                                     " not written: ", written.message()));
  }
  snapshot_position_.store(c->position, std::memory_order_release);
  snapshot_unix_ms_.store(NowUnixMs(), std::memory_order_release);
  if (c->prune_upto > pruned) {
    absl::Status s = options_.store->PruneJournal(id_, c->prune_upto);
    if (!s.ok()) {
      return absl::Status(s.code(),
                          absl::StrCat("journal of ", MapName(id_), " not pruned: ", s.message()));
    }
    pruned_position_.store(c->prune_upto, std::memory_order_release);
    (void)queue_.Submit([this, cut = c->prune_upto] {
      index_.MarkPruned(cut);
      journal_bytes_.store(index_.journal_bytes(), std::memory_order_relaxed);
    });
  }
  return absl::OkStatus();
}

}  // namespace skimap::server
