// Metrics: skimapd's Prometheus instruments (prometheus-cpp's core library: a Registry and
// its families) and their text exposition, served by the REST adapter at GET /metrics
// (no second HTTP server). The cores and adapters report through the narrow methods
// below; no prometheus type appears outside metrics.cc.
//
//   skimap_frames_ingested_total                     frames integrated and acknowledged
//   skimap_frames_refused_total{reason}              frames answered with an error; reason =
//                                                    the limit's flag (max_frame_pixels,
//                                                    queue_capacity, ...) or the status code
//   skimap_integration_seconds                       histogram: a frame on the map's worker
//                                                    (journal, decode, stages, apply)
//   skimap_journal_append_seconds                    histogram: one journal append (fsync)
//   skimap_recognition_frames_total                  frames recognition processed
//   skimap_map_queued_writes{map}                    gauges of the loaded maps, read at
//   skimap_map_voxels{map}                           each scrape (MapGaugeSource)
//   skimap_map_memory_bytes{map}
//   skimap_map_instances{map}
//   skimap_grpc_request_seconds{method,code}         histogram per gRPC method and code
//   skimap_http_request_seconds{route,code}          histogram per REST route and status
//   skimap_store_reconnects_total                    a PostgreSQL store's reconnects, its
//   skimap_store_unknown_commits_total{outcome}      COMMITs whose answer was lost (outcome:
//   skimap_store_standby_waits_total                 committed, not_committed, unresolved),
//   skimap_store_synchronous                         appends held for a synchronous standby
//                                                    and whether the primary replicates
//                                                    synchronously (1, 0; -1 not seen yet):
//                                                    read at each scrape (StoreGaugeSource)
//
//   Metrics metrics;
//   metrics.FrameIngested();
//   metrics.SetMapGaugeSource([&] { return maps.MetricGauges(); });
//   std::string text = metrics.Scrape();   // text exposition format 0.0.4
//
// Thread safety: thread safe; every method may be called from any thread.
#ifndef SERVER_CORE_METRICS_METRICS_H_
#define SERVER_CORE_METRICS_METRICS_H_

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/time/time.h"

namespace skimap::server {

class Metrics {
 public:
  // One loaded map's gauges.
  struct MapGauges {
    std::string map;  // "maps/kitchen"
    uint64_t queued_writes = 0;
    uint64_t voxels = 0;  // RGB and free-space volumes
    uint64_t memory_bytes = 0;
    uint64_t instances = 0;
  };
  using MapGaugeSource = std::function<std::vector<MapGauges>()>;
  // A PostgreSQL store's health (storage::PostgresMapStore::Health), cumulative.
  struct StoreGauges {
    uint64_t reconnects = 0;
    uint64_t unknown_commits = 0;
    uint64_t unknown_committed = 0;
    uint64_t unknown_not_committed = 0;
    uint64_t unknown_unresolved = 0;
    uint64_t standby_waits = 0;
    int synchronous = -1;
  };
  using StoreGaugeSource = std::function<StoreGauges()>;

  Metrics();
  ~Metrics();
  Metrics(const Metrics&) = delete;
  Metrics& operator=(const Metrics&) = delete;

  void FrameIngested();
  void FrameRefused(const absl::Status& status);  // REQUIRES: !status.ok()
  void IntegrationTook(absl::Duration d);
  void JournalAppendTook(absl::Duration d);
  void FrameRecognized();
  // A finished gRPC call: `method` as "skimap.v1.MapService/GetMap", `code` its status.
  void GrpcCallDone(std::string_view method, int code, absl::Duration d);
  // A finished REST call: `route` as "GET /v1/maps/{map}" ("static", "none" outside the
  // table), `status` the HTTP status.
  void HttpCallDone(std::string_view route, int status, absl::Duration d);

  // Called at each scrape for the per-map gauges (REQUIRES: what it reads outlives every
  // scrape). Maps it no longer lists leave the exposition.
  void SetMapGaugeSource(MapGaugeSource source);
  // Called at each scrape for the store's metrics (none without one).
  void SetStoreGaugeSource(StoreGaugeSource source);
  // Every metric in the Prometheus text exposition format (version 0.0.4).
  std::string Scrape();

 private:
  struct Instruments;  // metrics.cc: the registry and its families
  void ScrapeStore();  // REQUIRES: scrape_mu held
  std::unique_ptr<Instruments> in_;
};

// The `reason` label of a refused frame: the skimapd flag a limit's message names
// ("... (skimapd --max_frame_pixels)" -> "max_frame_pixels"), else the status code's name
// ("INVALID_ARGUMENT").
std::string RefusalReason(const absl::Status& status);

}  // namespace skimap::server

#endif  // SERVER_CORE_METRICS_METRICS_H_
