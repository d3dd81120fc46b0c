// MapService: the transport-independent core of the SkiMap API (proto/skimap/v1). Each
// method takes and returns the API's messages and reports errors as absl::Status with the
// codes documented in map_service.proto; the gRPC adapter (grpc_service.h) converts them
// once. Routes of the API map one-to-one onto these methods, but for the recognition calls
// (ListInstances, GetInstance, WatchInstances, GetLabelVoxels): InstanceQueries
// (server/core/recognition/instance_queries.h), over FindMap; and for ExportMap and
// ImportMap: MapTransfer (server/core/transfer/map_transfer.h).
//
//   MapService service({.worker_threads = 2});
//   absl::StatusOr<v1::Map> map = service.CreateMap(request);
//   service.IntegrateFrame(frame, [](absl::StatusOr<v1::FrameAck> ack) { ... });
//
// Thread safety: thread safe; every method may be called from any thread.
#ifndef SERVER_CORE_MAPS_MAP_SERVICE_H_
#define SERVER_CORE_MAPS_MAP_SERVICE_H_

#include <functional>
#include <memory>
#include <thread>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "base/mutex.h"
#include "base/thread_pool.h"
#include "server/core/common/work_queue.h"
#include "server/core/maps/map_ownership.h"
#include "server/core/maps/map_registry.h"
#include "server/core/metrics/metrics.h"
#include "skimap/v1/frames.pb.h"
#include "skimap/v1/maps.pb.h"
#include "skimap/v1/queries.pb.h"
#include "storage/map_store.h"

namespace skimap::server {

class MapService {
 public:
  struct Options {
    int worker_threads = 2;  // integration threads shared by all maps (0 = inline)
    // Niceness of the ingestion threads (integration pool, decoders, map workers; 0..19):
    // when ingestion saturates the cores, queries (on the adapters' threads, niceness 0)
    // still get most of a core. skimapd --ingest_nice.
    int ingest_nice = 5;
    size_t queue_capacity = 64;         // queued writes per map
    size_t max_frame_bytes = 64 << 20;  // encoded depth + colour; larger: ResourceExhausted
    // Largest frame in pixels (intrinsics width x height); larger: ResourceExhausted
    // naming skimapd --max_frame_pixels. 0 = only the API's 8192 x 8192.
    uint64_t max_frame_pixels = 0;
    // A map holding this many voxels (RGB and free-space volumes together) refuses further
    // frames with ResourceExhausted naming skimapd --max_map_voxels; checked before each
    // frame, so a frame that starts below the limit is integrated whole. 0 = no limit.
    uint64_t max_map_voxels = 0;
    size_t max_kept_frame_bytes = size_t{1} << 30;  // per map, for UpdatePoses
    size_t max_maps = 1000;  // maps per server (ResourceExhausted naming --max_maps)
    // Largest reply (the transport's message limit): grids and height maps that would not
    // fit are refused with ResourceExhausted before they are computed.
    size_t max_reply_bytes = 80 << 20;
    // Where maps persist (not owned; outlives the service). Null: in memory only.
    storage::MapStore* store = nullptr;
    // With a store: load every stored map at start (Recover), or each on its first use.
    bool lazy_load = false;
    // With a store: loaded maps beyond this many bytes are snapshotted and evicted, least
    // recently used first (map_registry.h); 0 = no limit.
    uint64_t memory_budget_bytes = 0;
    // With a store: a background thread snapshots each map whose journal has records no
    // snapshot covers, at this period, and right away once it has snapshot_records of them.
    absl::Duration snapshot_interval = absl::Seconds(10);
    uint64_t snapshot_records = 600;
    // Retention policy of the journal (LiveMap::Options::journal_retain_bytes).
    uint64_t journal_retain_bytes = uint64_t{1} << 30;
    // The object classifier for maps with recognition (LiveMap::Options::classifier).
    std::function<std::shared_ptr<const objects::ObjectDatabase>()> classifier;
    // A fleet node (server/core/fleet/fleet_node.h; not owned, outlives the service): every
    // request for a map claims it first (map_service_fleet.cc), maps are loaded on first
    // use, and ListMaps lists the store's maps with their owners. Null: a single server.
    MapOwnership* ownership = nullptr;
    // Frame counters and latencies (metrics/metrics.h; not owned, outlives the service);
    // null: none.
    Metrics* metrics = nullptr;
  };
  explicit MapService(const Options& options);
  ~MapService();

  // Lists every map of options.store and loads each (its latest snapshot, then the journal
  // after it), or registers it to load on first use with lazy_load; then starts the
  // snapshot thread. Maps of imports that did not finish are deleted. A map that cannot be loaded
  // answers its error (naming the map and the cause) to every request for it; the others load and
  // serve. Errors: the store's, if it cannot list the maps. REQUIRES: called once, before the
  // service takes requests.
  absl::Status Recover();
  // Snapshots every map with journal records no snapshot covers (blocking). Also run by the
  // snapshot thread and at destruction.
  void SnapshotAll() { registry_.Maintain(1); }
  // The gauges of every loaded map (queued writes, voxels, bytes, instances), for a
  // metrics scrape.
  std::vector<Metrics::MapGauges> MetricGauges() const;

  absl::StatusOr<v1::Map> CreateMap(const v1::CreateMapRequest& request);
  absl::StatusOr<v1::Map> GetMap(const v1::GetMapRequest& request) const;
  absl::StatusOr<v1::ListMapsResponse> ListMaps(const v1::ListMapsRequest& request) const;
  absl::Status DeleteMap(const v1::DeleteMapRequest& request);

  // Validates the envelope (map name, size) and queues the frame on its map's worker.
  // `done` runs exactly once, possibly before IntegrateFrame returns.
  void IntegrateFrame(std::shared_ptr<const v1::Frame> frame, LiveMap::FrameDone done);
  // Queues pose corrections; `done` runs exactly once.
  void UpdatePoses(std::shared_ptr<const v1::UpdatePosesRequest> request, LiveMap::PosesDone done);

  absl::StatusOr<v1::OccupancyGrid> GetOccupancyGrid(
      const v1::GetOccupancyGridRequest& request) const;
  absl::StatusOr<v1::HeightMap> GetHeightMap(const v1::GetHeightMapRequest& request) const;
  // One page of voxels; page tokens are opaque, bound to the map and the query (box,
  // min_voxel_weight), and stay valid while the map exists.
  absl::StatusOr<v1::GetVoxelsResponse> GetVoxels(const v1::GetVoxelsRequest& request) const;
  absl::StatusOr<v1::RadiusSearchResponse> RadiusSearch(
      const v1::RadiusSearchRequest& request) const;
  // The camera trajectory (the viewer's): each frame's pose by sequence, thinned evenly to
  // max_poses (the last frame kept). InvalidArgument for max_poses outside 0..100000.
  absl::StatusOr<v1::Trajectory> GetTrajectory(const v1::GetTrajectoryRequest& request) const;

  // WatchMap: a watch of one map's changes (the viewer's live updates). `wake` runs (on a
  // map thread, under a mutex: it must only schedule work) after each write that changed
  // map `request.name` (an integrated frame, a pose update) and once when it is deleted or
  // unloaded, until the watch is destroyed. Errors: the map's lookup (NotFound, ...).
  class MapWatch {
   public:
    ~MapWatch();
    // True once the watched map was deleted or unloaded: no more wakes will come.
    bool gone() const { return !map_->Refused().ok(); }

   private:
    friend class MapService;
    explicit MapWatch(std::shared_ptr<LiveMap> map) : map_(std::move(map)) {}
    std::shared_ptr<LiveMap> map_;
    uint64_t watcher_ = 0;
  };
  absl::StatusOr<std::unique_ptr<MapWatch>> WatchMap(const v1::GetMapRequest& request,
                                                     std::function<void()> wake) const;

  // The map a request names ("maps/{id}"; `field` is the request's field, for errors),
  // loaded: on a fleet node, claimed first (map_service_fleet.cc). For the cores built on
  // this one (recognition/instance_queries.h). Errors: InvalidArgument naming `field`,
  // NotFound, a redirect, the map's own (DataLoss for a corrupt map, ...).
  absl::StatusOr<std::shared_ptr<LiveMap>> FindMap(const std::string& name,
                                                   const char* field) const;
  // For the cores built on this one (transfer/map_transfer.h): the registry of maps and
  // the store (null: maps live in memory only).
  MapRegistry* registry() const { return &registry_; }
  storage::MapStore* store() const { return options_.store; }

 private:
  absl::Status CheckRecognition(const RecognitionConfig& config) const;

  v1::Map Describe(const MapRegistry::Listed& listed) const;
  // Fleet nodes (map_service_fleet.cc). ClaimMap: OK once this node may serve map `id`,
  // which it then (re)loads from the store if the lease was just taken; the claim's error
  // otherwise (NotFound, a redirect). SyncWithStore: registers the store's maps not known
  // here and forgets those deleted by other nodes. Owners: owner of each map, or empty.
  absl::Status ClaimMap(const std::string& id) const;
  void SyncWithStore() const;
  std::map<std::string, MapOwnership::Owner> Owners() const;
  void MaintenanceLoop();

  const Options options_;
  std::unique_ptr<ThreadPool> pool_;
  // Decodes frames' images ahead of the map workers (LiveMap::Options::decoder); declared
  // before the registry, so it outlives every map. A full queue makes a map decode inline.
  static constexpr size_t kDecoderCapacity = 256;
  std::unique_ptr<WorkQueue> decoder_;
  // Appends frames' journal records beside their staging (LiveMap::Options::journal);
  // declared before the registry, so it outlives every map.
  std::unique_ptr<WorkQueue> journal_;
  mutable MapRegistry registry_;  // mutable: a const query may load a map

  Mutex maintenance_mu_;
  CondVar maintenance_cv_;
  bool stopping_ ABSL_GUARDED_BY(maintenance_mu_) = false;
  std::thread maintenance_;
};

}  // namespace skimap::server

#endif  // SERVER_CORE_MAPS_MAP_SERVICE_H_
