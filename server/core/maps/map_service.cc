// MapService: maps and frames. Queries are in map_service_queries.cc.
#include "server/core/maps/map_service.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <utility>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "server/core/common/page_token.h"
#include "server/core/logging/log.h"

namespace skimap::server {
namespace {

MapRegistry::Options RegistryOptions(const MapService::Options& o, ThreadPool* pool,
                                     WorkQueue* decoder, WorkQueue* journal) {
  MapRegistry::Options r;
  r.map_defaults.pool = pool;
  r.map_defaults.decoder = decoder;
  r.map_defaults.journal = o.store != nullptr ? journal : nullptr;
  r.map_defaults.queue_capacity = o.queue_capacity;
  r.map_defaults.worker_nice = o.ingest_nice;
  r.map_defaults.max_kept_frame_bytes = o.max_kept_frame_bytes;
  r.map_defaults.store = o.store;
  r.map_defaults.journal_retain_bytes = o.journal_retain_bytes;
  r.map_defaults.classifier = o.classifier;
  r.map_defaults.metrics = o.metrics;
  r.max_maps = o.max_maps;
  r.memory_budget_bytes = o.memory_budget_bytes;
  return r;
}

}  // namespace

MapService::MapService(const Options& options)
    : options_(options),
      pool_(std::make_unique<ThreadPool>(options.worker_threads, options.ingest_nice)),
      decoder_(std::make_unique<WorkQueue>(
          WorkQueue::Options{.capacity = kDecoderCapacity,
                             .threads = std::max(2, options.worker_threads),
                             .nice = options.ingest_nice})),
      journal_(std::make_unique<WorkQueue>(
          WorkQueue::Options{.capacity = kDecoderCapacity, .threads = 2})),
      registry_(RegistryOptions(options, pool_.get(), decoder_.get(), journal_.get())) {
  if (options_.ownership != nullptr) {
    options_.ownership->OnLost([this](const std::string& id) { registry_.Unload(id); });
  }
}

MapService::~MapService() {
  if (maintenance_.joinable()) {
    {
      MutexLock lock(&maintenance_mu_);
      stopping_ = true;
    }
    maintenance_cv_.SignalAll();
    maintenance_.join();
  }
  // A last snapshot makes the next start replay nothing (recognition finished first).
  if (options_.store != nullptr) {
    registry_.ForEachLoaded([](LiveMap& map) { map.FlushRecognition(); });
    SnapshotAll();
  }
}

void MapService::MaintenanceLoop() {
  const absl::Duration tick = std::min(options_.snapshot_interval, absl::Seconds(1));
  absl::Time last_full = absl::Now();
  MutexLock lock(&maintenance_mu_);
  for (;;) {
    const auto wake = std::chrono::steady_clock::now() + absl::ToChronoMilliseconds(tick);
    while (!stopping_ && maintenance_cv_.WaitUntil(&maintenance_mu_, wake)) {
    }
    if (stopping_) return;
    lock.Unlock();
    const bool due = absl::Now() - last_full >= options_.snapshot_interval;
    registry_.Maintain(due ? 1 : options_.snapshot_records);
    if (due) last_full = absl::Now();
    lock.Lock();
  }
}

v1::Map MapService::Describe(const MapRegistry::Listed& listed) const {
  v1::Map out;
  out.set_name(MapName(listed.id));
  *out.mutable_options() = ToProto(listed.config);
  if (listed.map != nullptr) {
    *out.mutable_stats() = listed.map->Stats();
    return out;
  }
  // On disk only: the stats it had when evicted, and what the store says is durable.
  v1::MapStats& stats = *out.mutable_stats() = listed.last_stats;
  stats.set_loaded(false);
  stats.set_persistent(true);
  if (options_.store != nullptr) {
    if (absl::StatusOr<storage::StoredMap> m = options_.store->GetMap(listed.id); m.ok()) {
      stats.set_journal_position(m->last_position);
      stats.set_snapshot_position(m->snapshot_position);
      if (m->snapshot_unix_ms > 0) {
        stats.mutable_snapshot_time()->set_seconds(m->snapshot_unix_ms / 1000);
        stats.mutable_snapshot_time()->set_nanos(int32_t(m->snapshot_unix_ms % 1000) * 1000000);
      }
    }
  }
  return out;
}

absl::StatusOr<std::shared_ptr<LiveMap>> MapService::FindMap(const std::string& name,
                                                             const char* field) const {
  absl::StatusOr<std::string> id = ParseMapName(name, field);
  if (!id.ok()) return id.status();
  if (absl::Status s = ClaimMap(*id); !s.ok()) return s;
  return registry_.Get(*id);
}

absl::Status MapService::Recover() {
  if (options_.store == nullptr) return absl::OkStatus();
  absl::StatusOr<std::vector<storage::StoredMap>> stored = options_.store->ListMaps();
  if (!stored.ok()) return stored.status();
  for (const storage::StoredMap& m : *stored) {
    auto skip = [&](const absl::Status& why) {
      LogError(absl::StrCat("map ", MapName(m.id), " not loaded: ", why.ToString()));
    };
    // A fleet node does not own the maps of the store: it claims each on its first use (an
    // import left unfinished by a node that died is removed then).
    if (m.importing && options_.ownership != nullptr) continue;
    if (m.importing) {  // the process ended during the import: it never became a map
      absl::Status s = options_.store->DeleteMap(m.id);
      LogWarning(absl::StrCat("map ", MapName(m.id), ": removing an import that did not finish",
                              s.ok() ? "" : ": ", s.ok() ? "" : s.ToString()));
      continue;
    }
    v1::MapOptions proto;
    if (!proto.ParseFromString(m.options)) {
      skip(absl::DataLossError("stored options do not parse"));
      continue;
    }
    absl::StatusOr<MapConfig> config = ResolveStoredMapOptions(proto);
    if (!config.ok()) {
      skip(config.status());
      continue;
    }
    if (absl::Status s = registry_.AddStored(m.id, *config); !s.ok()) {
      skip(s);
      continue;
    }
    if (!options_.lazy_load && options_.ownership == nullptr) {
      (void)registry_.Get(m.id);  // an error stays with the map
    }
  }
  maintenance_ = std::thread([this] { MaintenanceLoop(); });
  return absl::OkStatus();
}

absl::StatusOr<v1::Map> MapService::CreateMap(const v1::CreateMapRequest& request) {
  if (absl::Status s = ValidateMapId(request.map_id(), "map_id"); !s.ok()) return s;
  absl::StatusOr<MapConfig> config = ResolveMapOptions(request.options());
  if (!config.ok()) return config.status();
  if (absl::Status s = CheckRecognition(config->recognition); !s.ok()) return s;
  if (options_.ownership != nullptr) SyncWithStore();  // ids taken or freed by other nodes
  absl::StatusOr<std::shared_ptr<LiveMap>> map = registry_.Create(request.map_id(), *config);
  if (!map.ok()) return map.status();
  if (options_.store != nullptr) {
    absl::Status stored =
        options_.store->CreateMap(request.map_id(), ToProto(*config).SerializeAsString());
    if (!stored.ok()) {
      (void)registry_.Delete(request.map_id());
      return absl::Status(stored.code(), absl::StrCat("map ", MapName(request.map_id()),
                                                      " not created: ", stored.message()));
    }
  }
  if (options_.ownership != nullptr) (void)ClaimMap(request.map_id());  // held since created
  LogInfo(absl::StrCat("map ", MapName(request.map_id()), " created"));
  return Describe({.id = request.map_id(), .config = *config, .map = *map});
}

absl::Status MapService::CheckRecognition(const RecognitionConfig& config) const {
  if (!config.enabled) return absl::OkStatus();
  std::shared_ptr<const objects::ObjectDatabase> db =
      options_.classifier ? options_.classifier() : nullptr;
  if (db == nullptr) {
    return absl::FailedPreconditionError(
        "options.recognition.enabled: the server has no object classifier yet (train objects "
        "and build it: skimap objects train, skimap objects build)");
  }
  for (size_t i = 0; i < config.obj_ids.size(); ++i) {
    if (db->FindObject(config.obj_ids[i]) < 0) {
      return absl::InvalidArgumentError(absl::StrCat("options.recognition.obj_ids[", i,
                                                     "]: object ", config.obj_ids[i],
                                                     " is not in the classifier"));
    }
  }
  return absl::OkStatus();
}

absl::StatusOr<v1::Map> MapService::GetMap(const v1::GetMapRequest& request) const {
  absl::StatusOr<std::shared_ptr<LiveMap>> map = FindMap(request.name(), "name");
  if (!map.ok()) return map.status();
  return Describe({.id = (*map)->id(), .config = (*map)->config(), .map = *map});
}

MapService::MapWatch::~MapWatch() {
  if (watcher_ != 0) map_->RemoveChangeWatcher(watcher_);
}

absl::StatusOr<std::unique_ptr<MapService::MapWatch>> MapService::WatchMap(
    const v1::GetMapRequest& request, std::function<void()> wake) const {
  absl::StatusOr<std::shared_ptr<LiveMap>> map = FindMap(request.name(), "name");
  if (!map.ok()) return map.status();
  std::unique_ptr<MapWatch> watch(new MapWatch(*map));
  watch->watcher_ = (*map)->AddChangeWatcher(std::move(wake));
  return watch;
}

absl::StatusOr<v1::ListMapsResponse> MapService::ListMaps(
    const v1::ListMapsRequest& request) const {
  if (request.page_size() < 0 || request.page_size() > 1000) {
    return absl::InvalidArgumentError("page_size must be in 0..1000");
  }
  const uint32_t query = QueryFingerprint(0, "ListMaps", "");
  std::string after;
  if (!request.page_token().empty()) {
    absl::StatusOr<std::string> id = DecodePageToken(request.page_token(), query);
    if (!id.ok()) return id.status();
    after = *id;
  }
  const size_t limit = request.page_size() == 0 ? 50 : request.page_size();
  if (options_.ownership != nullptr) SyncWithStore();  // maps of every node
  std::vector<MapRegistry::Listed> maps = registry_.List(after, limit + 1);
  const std::map<std::string, MapOwnership::Owner> owners = Owners();
  v1::ListMapsResponse response;
  for (size_t i = 0; i < maps.size() && i < limit; ++i) {
    v1::Map* map = response.add_maps();
    auto owner = owners.find(maps[i].id);
    // Not served here: a copy here (if any) may not be current; the store's stats.
    if (owner != owners.end() && !owner->second.here) maps[i].map = nullptr;
    *map = Describe(maps[i]);
    if (owner != owners.end() && owner->second.live) {
      map->set_owner_node(owner->second.node);
      map->set_owner_address(owner->second.address);
    }
  }
  if (maps.size() > limit) response.set_next_page_token(EncodePageToken(query, maps[limit - 1].id));
  return response;
}

absl::Status MapService::DeleteMap(const v1::DeleteMapRequest& request) {
  absl::StatusOr<std::string> id = ParseMapName(request.name(), "name");
  if (!id.ok()) return id.status();
  if (absl::Status s = ClaimMap(*id); !s.ok()) return s;
  if (absl::Status s = registry_.Delete(*id); !s.ok()) return s;
  if (options_.store != nullptr) {
    absl::Status s = options_.store->DeleteMap(*id);
    if (!s.ok() && !absl::IsNotFound(s)) {
      return absl::Status(s.code(), absl::StrCat("map ", MapName(*id),
                                                 ": removed from memory, its data on disk not "
                                                 "deleted: ",
                                                 s.message()));
    }
  }
  LogInfo(absl::StrCat("map ", MapName(*id), " deleted"));
  return absl::OkStatus();
}

std::vector<Metrics::MapGauges> MapService::MetricGauges() const {
  std::vector<Metrics::MapGauges> gauges;
  registry_.ForEachLoaded([&gauges](LiveMap& map) {
    const v1::MapStats stats = map.Stats();
    gauges.push_back({.map = MapName(map.id()),
                      .queued_writes = map.queued_writes(),
                      .voxels = stats.voxels() + stats.free_voxels(),
                      .memory_bytes = stats.memory_bytes(),
                      .instances = stats.instances()});
  });
  return gauges;
}

void MapService::IntegrateFrame(std::shared_ptr<const v1::Frame> frame, LiveMap::FrameDone done) {
  // Counted (metrics.h) and, when refused, logged with the reason, wherever it is answered.
  done = [metrics = options_.metrics, map = frame->map().substr(0, 256),
          sequence = frame->sequence(), done = std::move(done)](absl::StatusOr<v1::FrameAck> ack) {
    if (ack.ok()) {
      if (metrics != nullptr) metrics->FrameIngested();
    } else {
      if (metrics != nullptr) metrics->FrameRefused(ack.status());
      Log({.level = LogLevel::kWarning,
           .msg = absl::StrCat("frame ", sequence, " refused: ", ack.status().ToString()),
           .map = map,
           .code = static_cast<int>(ack.status().code())});
    }
    done(std::move(ack));
  };
  const size_t bytes = frame->depth().size() + frame->color().size();
  if (bytes > options_.max_frame_bytes) {
    return done(absl::ResourceExhaustedError(
        absl::StrCat("depth+color: frame images are ", bytes, " bytes, limit ",
                     options_.max_frame_bytes, " (80 % of skimapd --max_message_mb)")));
  }
  const uint64_t pixels = uint64_t{frame->intrinsics().width()} * frame->intrinsics().height();
  if (options_.max_frame_pixels > 0 && pixels > options_.max_frame_pixels) {
    return done(absl::ResourceExhaustedError(
        absl::StrCat("intrinsics: ", frame->intrinsics().width(), " x ",
                     frame->intrinsics().height(), " pixels exceed the limit of ",
                     options_.max_frame_pixels, " pixels per frame (skimapd --max_frame_pixels)")));
  }
  absl::StatusOr<std::shared_ptr<LiveMap>> map = FindMap(frame->map(), "map");
  if (!map.ok()) return done(map.status());
  if (options_.max_map_voxels > 0) {
    const uint64_t voxels =
        (*map)->Read([](const MapState& s) { return s.rgb.size() + s.free.size(); });
    if (voxels >= options_.max_map_voxels) {
      return done(absl::ResourceExhaustedError(absl::StrCat(
          "map ", MapName((*map)->id()), " holds ", voxels, " voxels, the limit is ",
          options_.max_map_voxels, " per map (skimapd --max_map_voxels); frame not integrated")));
    }
  }
  (*map)->SubmitFrame(std::move(frame), std::move(done));
}

void MapService::UpdatePoses(std::shared_ptr<const v1::UpdatePosesRequest> request,
                             LiveMap::PosesDone done) {
  absl::StatusOr<std::shared_ptr<LiveMap>> map = FindMap(request->map(), "map");
  if (!map.ok()) return done(map.status());
  (*map)->SubmitPoseUpdates(std::move(request), std::move(done));
}

}  // namespace skimap::server
