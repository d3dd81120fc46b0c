#include "server/core/metrics/metrics.h"

#include <prometheus/counter.h>
#include <prometheus/family.h>
#include <prometheus/gauge.h>
#include <prometheus/histogram.h>
#include <prometheus/registry.h>
#include <prometheus/text_serializer.h>

#include <map>
#include <mutex>
#include <utility>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"

namespace skimap::server {

using prometheus::BuildCounter;
using prometheus::BuildGauge;
using prometheus::BuildHistogram;
using prometheus::Counter;
using prometheus::Family;
using prometheus::Gauge;
using prometheus::Histogram;

namespace {

// Seconds: 0.1 ms .. 10 s.
const Histogram::BucketBoundaries kLatency = {0.0001, 0.00025, 0.0005, 0.001, 0.0025, 0.005,
                                              0.01,   0.025,   0.05,   0.1,   0.25,   0.5,
                                              1,      2.5,     5,      10};

const char* GrpcCodeName(int code) {
  static const char* const kNames[] = {"OK",
                                       "CANCELLED",
                                       "UNKNOWN",
                                       "INVALID_ARGUMENT",
                                       "DEADLINE_EXCEEDED",
                                       "NOT_FOUND",
                                       "ALREADY_EXISTS",
                                       "PERMISSION_DENIED",
                                       "RESOURCE_EXHAUSTED",
                                       "FAILED_PRECONDITION",
                                       "ABORTED",
                                       "OUT_OF_RANGE",
                                       "UNIMPLEMENTED",
                                       "INTERNAL",
                                       "UNAVAILABLE",
                                       "DATA_LOSS",
                                       "UNAUTHENTICATED"};
  return code >= 0 && code <= 16 ? kNames[code] : "UNKNOWN";
}

}  // namespace

struct Metrics::Instruments {
  prometheus::Registry registry;
  Counter& ingested = BuildCounter()
                          .Name("skimap_frames_ingested_total")
                          .Help("Frames integrated and acknowledged")
                          .Register(registry)
                          .Add({});
  Family<Counter>& refused = BuildCounter()
                                 .Name("skimap_frames_refused_total")
                                 .Help("Frames answered with an error, by reason (limit or code)")
                                 .Register(registry);
  Histogram& integration =
      BuildHistogram()
          .Name("skimap_integration_seconds")
          .Help("Time of one frame on its map's worker: journal, decode, stages, apply")
          .Register(registry)
          .Add({}, kLatency);
  Histogram& journal = BuildHistogram()
                           .Name("skimap_journal_append_seconds")
                           .Help("Time of one journal append, fsync included")
                           .Register(registry)
                           .Add({}, kLatency);
  Counter& recognized = BuildCounter()
                            .Name("skimap_recognition_frames_total")
                            .Help("Frames processed by recognition")
                            .Register(registry)
                            .Add({});
  Family<Gauge>& queued = BuildGauge()
                              .Name("skimap_map_queued_writes")
                              .Help("Writes queued on a loaded map's worker")
                              .Register(registry);
  Family<Gauge>& voxels = BuildGauge()
                              .Name("skimap_map_voxels")
                              .Help("Voxels of a loaded map (RGB and free-space volumes)")
                              .Register(registry);
  Family<Gauge>& bytes = BuildGauge()
                             .Name("skimap_map_memory_bytes")
                             .Help("Bytes held by a loaded map's volumes")
                             .Register(registry);
  Family<Gauge>& instances = BuildGauge()
                                 .Name("skimap_map_instances")
                                 .Help("Object instances of a loaded map")
                                 .Register(registry);
  Family<Histogram>& grpc = BuildHistogram()
                                .Name("skimap_grpc_request_seconds")
                                .Help("gRPC calls by method and status code")
                                .Register(registry);
  Family<Histogram>& http = BuildHistogram()
                                .Name("skimap_http_request_seconds")
                                .Help("REST calls by route and HTTP status")
                                .Register(registry);

  std::mutex scrape_mu;  // one scrape at a time; guards the members below
  MapGaugeSource source;
  StoreGaugeSource store_source;
  StoreGauges store_seen;  // the store's counters at the last scrape
  // Registered with the first store scrape (a server without one shows none).
  Counter* store_reconnects = nullptr;
  Counter* store_committed = nullptr;
  Counter* store_not_committed = nullptr;
  Counter* store_unresolved = nullptr;
  Counter* store_waits = nullptr;
  Gauge* store_synchronous = nullptr;
  std::map<std::string, std::vector<Gauge*>> map_gauges;  // map -> its gauges, as added
};

Metrics::Metrics() : in_(std::make_unique<Instruments>()) {}
Metrics::~Metrics() = default;

void Metrics::FrameIngested() { in_->ingested.Increment(); }

void Metrics::FrameRefused(const absl::Status& status) {
  in_->refused.Add({{"reason", RefusalReason(status)}}).Increment();
}

void Metrics::IntegrationTook(absl::Duration d) {
  in_->integration.Observe(absl::ToDoubleSeconds(d));
}

void Metrics::JournalAppendTook(absl::Duration d) {
  in_->journal.Observe(absl::ToDoubleSeconds(d));
}

void Metrics::FrameRecognized() { in_->recognized.Increment(); }

void Metrics::GrpcCallDone(std::string_view method, int code, absl::Duration d) {
  in_->grpc.Add({{"method", std::string(method)}, {"code", GrpcCodeName(code)}}, kLatency)
      .Observe(absl::ToDoubleSeconds(d));
}

void Metrics::HttpCallDone(std::string_view route, int status, absl::Duration d) {
  in_->http.Add({{"route", std::string(route)}, {"code", absl::StrCat(status)}}, kLatency)
      .Observe(absl::ToDoubleSeconds(d));
}

void Metrics::SetMapGaugeSource(MapGaugeSource source) {
  std::lock_guard<std::mutex> lock(in_->scrape_mu);
  in_->source = std::move(source);
}

void Metrics::SetStoreGaugeSource(StoreGaugeSource source) {
  std::lock_guard<std::mutex> lock(in_->scrape_mu);
  in_->store_source = std::move(source);
}

void Metrics::ScrapeStore() {
  if (!in_->store_source) return;
  const StoreGauges now = in_->store_source();
  StoreGauges& seen = in_->store_seen;
  auto counter = [&](const char* name, const char* help) -> Family<Counter>& {
    return BuildCounter().Name(name).Help(help).Register(in_->registry);
  };
  if (in_->store_reconnects == nullptr) {
    in_->store_reconnects =
        &counter("skimap_store_reconnects_total",
                 "Connections of the PostgreSQL store re-established after a loss")
             .Add({});
    Family<Counter>& unknown = counter("skimap_store_unknown_commits_total",
                                       "COMMITs whose answer was lost, by what reading back found");
    in_->store_committed = &unknown.Add({{"outcome", "committed"}});
    in_->store_not_committed = &unknown.Add({{"outcome", "not_committed"}});
    in_->store_unresolved = &unknown.Add({{"outcome", "unresolved"}});
    in_->store_waits = &counter("skimap_store_standby_waits_total",
                                "Journal appends held back for want of a synchronous standby")
                            .Add({});
    in_->store_synchronous =
        &BuildGauge()
             .Name("skimap_store_synchronous")
             .Help(
                 "1 when the store's primary replicates synchronously, 0 when not, -1 before "
                 "the first append")
             .Register(in_->registry)
             .Add({});
  }
  auto add = [](Counter* c, uint64_t now, uint64_t before) {
    if (now > before) c->Increment(static_cast<double>(now - before));
  };
  add(in_->store_reconnects, now.reconnects, seen.reconnects);
  add(in_->store_committed, now.unknown_committed, seen.unknown_committed);
  add(in_->store_unresolved, now.unknown_unresolved, seen.unknown_unresolved);
  add(in_->store_not_committed, now.unknown_not_committed, seen.unknown_not_committed);
  add(in_->store_waits, now.standby_waits, seen.standby_waits);
  in_->store_synchronous->Set(now.synchronous);
  seen = now;
}

std::string Metrics::Scrape() {
  {
    std::lock_guard<std::mutex> lock(in_->scrape_mu);
    std::map<std::string, std::vector<Gauge*>> now;
    if (in_->source) {
      for (const MapGauges& g : in_->source()) {
        const prometheus::Labels labels = {{"map", g.map}};
        std::vector<Gauge*>& gauges = now[g.map];
        gauges = {&in_->queued.Add(labels), &in_->voxels.Add(labels), &in_->bytes.Add(labels),
                  &in_->instances.Add(labels)};
        gauges[0]->Set(static_cast<double>(g.queued_writes));
        gauges[1]->Set(static_cast<double>(g.voxels));
        gauges[2]->Set(static_cast<double>(g.memory_bytes));
        gauges[3]->Set(static_cast<double>(g.instances));
      }
    }
    for (const auto& [map, gauges] : in_->map_gauges) {
      if (now.count(map)) continue;
      in_->queued.Remove(gauges[0]);
      in_->voxels.Remove(gauges[1]);
      in_->bytes.Remove(gauges[2]);
      in_->instances.Remove(gauges[3]);
    }
    in_->map_gauges = std::move(now);
    ScrapeStore();
  }
  return prometheus::TextSerializer().Serialize(in_->registry.Collect());
}

std::string RefusalReason(const absl::Status& status) {
  const absl::string_view message = status.message();
  if (const size_t at = message.find("skimapd --"); at != absl::string_view::npos) {
    size_t end = at + 10;
    while (end < message.size() &&
           (absl::ascii_islower(static_cast<unsigned char>(message[end])) || message[end] == '_')) {
      ++end;
    }
    if (end > at + 10) return std::string(message.substr(at + 10, end - at - 10));
  }
  return GrpcCodeName(static_cast<int>(status.code()));
}

}  // namespace skimap::server
