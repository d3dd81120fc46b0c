// skimapd: the SkiMap map server.
//
//   skimapd [--address=127.0.0.1:50051 [--insecure]] [--data_dir=out/skimapd-data]
//           [--worker_threads=2] [--max_message_mb=80] [--max_in_flight=8]
//           [--queue_capacity=64] [--dataset_root=DIR] [--lazy_load]
//           [--memory_budget_mb=0] [--snapshot_interval_s=10] [--journal_retain_mb=1024]
//           [--max_maps=1000] [--max_map_voxels=0] [--max_frame_pixels=0]
//           [--max_streams_per_client=16]
//           [--http_address=127.0.0.1:8080] [--http_max_body_mb=32]
//           [--http_cors_origins=ORIGIN,...] [--http_threads=8]
//           [--web_root=DIR] [--http_max_event_streams=4]
//           [--log_format=text|json] [--metrics_public=true]
//           [--store=postgresql://user@host:port/db [--advertise_address=HOST:PORT]
//            [--lease_ttl_ms=6000] [--store_durability=auto|standby|primary]
//            [--store_failover_timeout_ms=30000] [--store_statement_timeout_ms=5000]]
//           [--auth_tokens_file=FILE] [--tls_cert=PEM --tls_key=PEM [--tls_client_ca=PEM]]
//
// With --auth_tokens_file every call but health needs a bearer token of the right role
// (docs/operations.md, "Authentication"); SIGHUP reads the file again (a file that does not
// parse keeps the previous tokens). --tls_cert/--tls_key serve gRPC over TLS and REST over
// HTTPS; --tls_client_ca requires client certificates from that CA on both (mTLS).
//
// With --store=postgresql://... the server is one node of a fleet sharing that store
// (docs/operations.md): it serves the maps whose lease it holds, takes the lease of a map
// without a live owner on the first request for it, and redirects requests for maps other
// nodes own (FleetService lists the nodes).
// Serves skimap.v1.MapService, skimap.v1.ObjectService (its object database is
// DATA_DIR/objects.sqlite, loaded at start), grpc.health.v1.Health and server reflection
// over gRPC, and the REST API (docs/api.md, "REST") over HTTP on --http_address.
// Stops cleanly on SIGINT or SIGTERM: no new calls, open calls get a 2 s grace period,
// queued frames are finished.
#include <pthread.h>
#include <signal.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <string>

#include "absl/flags/flag.h"
#include "absl/flags/parse.h"
#include "absl/flags/usage.h"
#include "absl/strings/ascii.h"
#include "absl/strings/str_split.h"
#include "server/app/malloc_tuning.h"
#include "server/app/server.h"
#include "server/core/logging/log.h"
#include "server/grpc/grpc_log.h"

ABSL_FLAG(std::string, address, "127.0.0.1:50051",
          "gRPC listen address (host:port); beyond loopback only with --auth_tokens_file or "
          "--insecure");
ABSL_FLAG(bool, insecure, false,
          "allow --address and --http_address beyond loopback without authentication (anyone "
          "who reaches the port can read and write every map)");
ABSL_FLAG(std::string, auth_tokens_file, "",
          "bearer tokens, one per line: <token> <role: read|write|admin> [<map>,...]; every "
          "call but health then needs one (SIGHUP reloads the file); empty: no authentication");
ABSL_FLAG(std::string, tls_cert, "",
          "PEM certificate chain: gRPC over TLS and REST over HTTPS (with --tls_key)");
ABSL_FLAG(std::string, tls_key, "", "PEM private key of --tls_cert");
ABSL_FLAG(std::string, tls_client_ca, "",
          "PEM CA certificates: clients must present a certificate signed by them (mTLS, gRPC "
          "and HTTPS)");
ABSL_FLAG(std::string, http_address, "127.0.0.1:8080",
          "REST (HTTP/1.1 + JSON) listen address (host:port); empty: no HTTP; beyond "
          "loopback only with --insecure");
ABSL_FLAG(int, http_max_body_mb, 32, "largest REST request body in MiB; larger: 413");
ABSL_FLAG(std::string, http_cors_origins, "",
          "comma list of origins allowed to call the REST API from a browser "
          "(https://host:port), or * for any; empty: none");
ABSL_FLAG(int, http_threads, 8, "REST requests served at once");
// The default: the viewer built in the source tree (web/dist beside CMakeLists.txt), if it
// was built; docs/viewer.md.
ABSL_FLAG(std::string, web_root, "default",
          "directory of the browser viewer's files (web/dist), served at / on --http_address; "
          "empty: no viewer; \"default\": the source tree's web/dist (" SKIMAP_WEB_DIST
          ") if it was built, else none");
ABSL_FLAG(int, http_max_event_streams, 4,
          "live-update streams (GET /v1/maps/{map}/events) open at once, each holding one of "
          "--http_threads; more: 429");
ABSL_FLAG(std::string, dataset_root, "",
          "directory under which TrainObjectFromDataset may read datasets; empty: off");
ABSL_FLAG(std::string, model_renderer, "default",
          "skimap-model-views, which renders AddObjectModel's uploaded 3D models in a process "
          "of its own; \"default\": the one beside this skimapd binary, if any; empty: "
          "AddObjectModel off");
ABSL_FLAG(int, model_render_timeout_s, 600,
          "AddObjectModel: seconds one model may take to read and render (then it is killed)");
ABSL_FLAG(std::string, data_dir, "out/skimapd-data",
          "directory for server data (created if missing): maps.sqlite holds every map (frame "
          "journal and snapshots, reloaded at start), objects.sqlite the object database");
ABSL_FLAG(std::string, store, "",
          "where maps persist: empty for DATA_DIR/maps.sqlite (SQLite), or a PostgreSQL "
          "connection URI (postgresql://user@host:port/db) or libpq connection string");
ABSL_FLAG(std::string, advertise_address, "",
          "with a PostgreSQL --store: where other nodes and clients reach this node "
          "(host:port); default --address");
ABSL_FLAG(int, lease_ttl_ms, 6000,
          "with a PostgreSQL --store: map leases and heartbeats expire after this long without "
          "renewal (renewed every third of it); a dead node's maps move after about this long");
ABSL_FLAG(std::string, store_durability, "auto",
          "with a PostgreSQL --store: what a frame's acknowledgement means. standby: the record "
          "is on the primary and a synchronous standby (start refused unless the primary "
          "replicates synchronously; appends wait while no standby is attached); primary: on "
          "the primary's disk; auto: standby when --store lists several hosts, else primary");
ABSL_FLAG(int, store_failover_timeout_ms, 30000,
          "with a PostgreSQL --store: how long a store call keeps reconnecting (to whichever "
          "host is primary) and an append waits for a synchronous standby before the call "
          "fails UNAVAILABLE");
ABSL_FLAG(int, store_statement_timeout_ms, 5000,
          "with a PostgreSQL --store: a statement without an answer for this long costs its "
          "connection (a primary that stopped answering: SIGSTOP, a partition), and the call "
          "goes on through a reconnect");
ABSL_FLAG(std::string, log_format, "text",
          "stderr log: text (\"skimapd: message\" lines) or json (one JSON object per line: "
          "time, level, msg, request_id, method or route, map, code, latency_ms; plus one "
          "access line per call)");
ABSL_FLAG(bool, metrics_public, true,
          "GET /metrics (Prometheus text on --http_address) answers without a token when "
          "authentication is configured; false: it needs a token like the other routes");
ABSL_FLAG(int, worker_threads, 2, "integration threads shared by all maps");
ABSL_FLAG(int, ingest_nice, 5,
          "scheduling niceness (0..19) of the ingestion threads (integration, decoding, map "
          "workers): when ingestion saturates the cores, queries still get most of a core");
ABSL_FLAG(int, max_message_mb, 80, "largest gRPC message in MiB (frames are limited to 80%)");
ABSL_FLAG(int, max_in_flight, 8, "unacknowledged frames per StreamFrames call");
ABSL_FLAG(int, queue_capacity, 64, "queued writes per map before RESOURCE_EXHAUSTED");
ABSL_FLAG(int, max_maps, 1000, "maps per server; CreateMap / ImportMap beyond: RESOURCE_EXHAUSTED");
ABSL_FLAG(int64_t, max_map_voxels, 0,
          "voxels per map; a map holding this many refuses further frames with "
          "RESOURCE_EXHAUSTED; 0 = no limit");
ABSL_FLAG(int64_t, max_frame_pixels, 0,
          "pixels per frame (width x height); larger frames: RESOURCE_EXHAUSTED; 0 = only the "
          "API's 8192 x 8192");
ABSL_FLAG(int, max_streams_per_client, 16,
          "open StreamFrames calls per client (peer address); the next: RESOURCE_EXHAUSTED; "
          "0 = no limit");
ABSL_FLAG(bool, lazy_load, false,
          "load each stored map on its first use instead of all of them at start");
ABSL_FLAG(int64_t, memory_budget_mb, 0,
          "loaded maps beyond this many MiB are snapshotted and evicted, least recently used "
          "first, and reloaded on their next use; 0 = no limit");
ABSL_FLAG(int, snapshot_interval_s, 10,
          "seconds between background snapshots of maps with new journal records");
ABSL_FLAG(int64_t, journal_retain_mb, 1024,
          "retention policy: once snapshotted, the oldest frame records of a map are pruned "
          "from the journal while its frame records exceed this many MiB (UpdatePoses on a "
          "pruned frame answers FAILED_PRECONDITION)");

namespace {

// --model_renderer: "default" is skimap-model-views beside this binary ("" if it is not
// there: AddObjectModel then answers FAILED_PRECONDITION).
std::string ModelRendererPath(const std::string& flag) {
  if (flag != "default") return flag;
  std::error_code ec;
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (ec) return "";
  const std::filesystem::path beside = self.parent_path() / "skimap-model-views";
  return std::filesystem::is_regular_file(beside, ec) ? beside.string() : "";
}

}  // namespace

int main(int argc, char** argv) {
  skimap::server::TuneMallocForServer();
  absl::SetProgramUsageMessage("SkiMap map server: skimapd [--address=host:port] ...");
  absl::ParseCommandLine(argc, argv);
  if (const std::string format = absl::GetFlag(FLAGS_log_format); format == "json") {
    skimap::server::SetLogFormat(skimap::server::LogFormat::kJson);
    skimap::server::RouteGrpcLogToLog();
  } else if (format != "text") {
    std::fprintf(stderr, "skimapd: --log_format must be text or json\n");
    return 2;
  }

  // A client that closes an HTTPS connection while we write must not kill the server:
  // OpenSSL writes with write(2), which raises SIGPIPE (plain sockets use MSG_NOSIGNAL).
  signal(SIGPIPE, SIG_IGN);
  // Block the stop signals in every thread (gRPC's included); main waits for them below.
  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGINT);
  sigaddset(&stop_signals, SIGTERM);
  sigaddset(&stop_signals, SIGHUP);  // reloads the token file
  pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);

  std::error_code ec;
  const std::string data_dir = absl::GetFlag(FLAGS_data_dir);
  std::filesystem::create_directories(data_dir, ec);
  if (ec) {
    std::fprintf(stderr, "skimapd: cannot create --data_dir %s: %s\n", data_dir.c_str(),
                 ec.message().c_str());
    return 1;
  }
  const int max_message_mb = absl::GetFlag(FLAGS_max_message_mb);
  if (max_message_mb < 1 || max_message_mb > 1024 || absl::GetFlag(FLAGS_worker_threads) < 0 ||
      absl::GetFlag(FLAGS_max_in_flight) < 1 || absl::GetFlag(FLAGS_queue_capacity) < 1 ||
      absl::GetFlag(FLAGS_memory_budget_mb) < 0 || absl::GetFlag(FLAGS_snapshot_interval_s) < 1 ||
      absl::GetFlag(FLAGS_journal_retain_mb) < 0 || absl::GetFlag(FLAGS_max_maps) < 1 ||
      absl::GetFlag(FLAGS_max_map_voxels) < 0 || absl::GetFlag(FLAGS_max_frame_pixels) < 0 ||
      absl::GetFlag(FLAGS_max_streams_per_client) < 0 || absl::GetFlag(FLAGS_lease_ttl_ms) < 100 ||
      absl::GetFlag(FLAGS_store_failover_timeout_ms) < 0 ||
      absl::GetFlag(FLAGS_store_statement_timeout_ms) < 100 ||
      absl::GetFlag(FLAGS_http_max_body_mb) < 1 || absl::GetFlag(FLAGS_http_max_body_mb) > 4096 ||
      absl::GetFlag(FLAGS_http_threads) < 1 || absl::GetFlag(FLAGS_http_max_event_streams) < 0 ||
      absl::GetFlag(FLAGS_ingest_nice) < 0 || absl::GetFlag(FLAGS_ingest_nice) > 19) {
    std::fprintf(stderr, "skimapd: flag out of range (see --help)\n");
    return 2;
  }
  skimap::server::Server::Options options;
  options.grpc.address = absl::GetFlag(FLAGS_address);
  options.grpc.insecure = absl::GetFlag(FLAGS_insecure);
  options.grpc.max_message_bytes = max_message_mb << 20;
  options.grpc.map_service.max_in_flight = absl::GetFlag(FLAGS_max_in_flight);
  options.grpc.map_service.max_streams_per_client = absl::GetFlag(FLAGS_max_streams_per_client);
  options.auth_tokens_file = absl::GetFlag(FLAGS_auth_tokens_file);
  options.grpc.tls = {.cert = absl::GetFlag(FLAGS_tls_cert),
                      .key = absl::GetFlag(FLAGS_tls_key),
                      .client_ca = absl::GetFlag(FLAGS_tls_client_ca)};
  options.http.tls = options.grpc.tls;
  options.http.address = absl::GetFlag(FLAGS_http_address);
  options.http.insecure = absl::GetFlag(FLAGS_insecure);
  options.http.max_body_bytes = size_t(absl::GetFlag(FLAGS_http_max_body_mb)) << 20;
  options.http.threads = absl::GetFlag(FLAGS_http_threads);
  options.http.web_root = absl::GetFlag(FLAGS_web_root);
  if (options.http.web_root == "default") {
    options.http.web_root.clear();
    if (std::filesystem::is_regular_file(std::filesystem::path(SKIMAP_WEB_DIST) / "index.html",
                                         ec)) {
      options.http.web_root = SKIMAP_WEB_DIST;
    }
  }
  options.metrics_public = absl::GetFlag(FLAGS_metrics_public);
  options.events.max_clients = absl::GetFlag(FLAGS_http_max_event_streams);
  for (absl::string_view origin :
       absl::StrSplit(absl::GetFlag(FLAGS_http_cors_origins), ',', absl::SkipWhitespace())) {
    options.http.cors_origins.emplace_back(absl::StripAsciiWhitespace(origin));
  }
  options.maps.max_frame_bytes = size_t(options.grpc.max_message_bytes) / 5 * 4;
  options.maps.worker_threads = absl::GetFlag(FLAGS_worker_threads);
  options.maps.ingest_nice = absl::GetFlag(FLAGS_ingest_nice);
  options.maps.queue_capacity = absl::GetFlag(FLAGS_queue_capacity);
  options.maps.lazy_load = absl::GetFlag(FLAGS_lazy_load);
  options.maps.memory_budget_bytes = uint64_t(absl::GetFlag(FLAGS_memory_budget_mb)) << 20;
  options.maps.snapshot_interval = absl::Seconds(absl::GetFlag(FLAGS_snapshot_interval_s));
  options.maps.journal_retain_bytes = uint64_t(absl::GetFlag(FLAGS_journal_retain_mb)) << 20;
  options.maps.max_maps = size_t(absl::GetFlag(FLAGS_max_maps));
  options.maps.max_map_voxels = uint64_t(absl::GetFlag(FLAGS_max_map_voxels));
  options.maps.max_frame_pixels = uint64_t(absl::GetFlag(FLAGS_max_frame_pixels));
  options.objects.dataset_root = absl::GetFlag(FLAGS_dataset_root);
  options.objects.db_path = (std::filesystem::path(data_dir) / "objects.sqlite").string();
  options.objects.model_renderer.binary = ModelRendererPath(absl::GetFlag(FLAGS_model_renderer));
  options.objects.model_renderer.timeout_seconds =
      std::max(1, absl::GetFlag(FLAGS_model_render_timeout_s));
  options.objects.model_scratch_dir = (std::filesystem::path(data_dir) / "model-uploads").string();
  options.objects.threads = std::max(1, absl::GetFlag(FLAGS_worker_threads));
  options.maps_db_path = (std::filesystem::path(data_dir) / "maps.sqlite").string();
  // With a PostgreSQL --store this server is a node of a fleet (libpq's messages name
  // host and port, never the password).
  options.fleet.store_url = absl::GetFlag(FLAGS_store);
  options.fleet.advertise_address = absl::GetFlag(FLAGS_advertise_address);
  options.fleet.lease_ttl = absl::Milliseconds(absl::GetFlag(FLAGS_lease_ttl_ms));
  options.fleet.durability = absl::GetFlag(FLAGS_store_durability);
  options.fleet.failover_timeout =
      absl::Milliseconds(absl::GetFlag(FLAGS_store_failover_timeout_ms));
  options.fleet.statement_timeout =
      absl::Milliseconds(absl::GetFlag(FLAGS_store_statement_timeout_ms));
  absl::StatusOr<std::unique_ptr<skimap::server::Server>> server =
      skimap::server::Server::Start(options);
  if (!server.ok()) {
    std::fprintf(stderr, "skimapd: %s\n", server.status().ToString().c_str());
    return 1;
  }
  skimap::server::Fleet* fleet = (*server)->fleet();
  std::printf("skimapd: listening on port %d (address %s), data dir %s%s%s\n",
              (*server)->grpc_port(), options.grpc.address.c_str(), data_dir.c_str(),
              fleet ? ", fleet node " : "", fleet ? fleet->node().node_id().c_str() : "");
  if ((*server)->http_port() != 0) {
    std::printf("skimapd: REST on http port %d (address %s)\n", (*server)->http_port(),
                options.http.address.c_str());
    std::printf("skimapd: viewer %s\n", options.http.web_root.empty()
                                            ? "off (no --web_root; build web/ to get one)"
                                            : ("at / from " + options.http.web_root).c_str());
  }
  std::fflush(stdout);

  if (!options.auth_tokens_file.empty()) {
    std::printf("skimapd: bearer tokens from %s\n", options.auth_tokens_file.c_str());
  }
  if (options.grpc.tls.enabled()) {
    std::printf("skimapd: TLS on gRPC and REST%s\n",
                options.grpc.tls.client_ca.empty() ? "" : ", client certificates required");
  }
  std::fflush(stdout);

  int signal_number = 0;
  for (;;) {
    sigwait(&stop_signals, &signal_number);
    if (signal_number != SIGHUP) break;
    // Messages name the file and the line, never a token.
    if (absl::Status s = (*server)->ReloadTokens(); !s.ok()) {
      std::fprintf(stderr, "skimapd: SIGHUP: %s; the previous tokens stay\n", s.ToString().c_str());
    } else {
      std::printf("skimapd: SIGHUP: tokens reloaded from %s\n", options.auth_tokens_file.c_str());
      std::fflush(stdout);
    }
  }
  std::printf("skimapd: %s, shutting down\n", signal_number == SIGINT ? "SIGINT" : "SIGTERM");
  std::fflush(stdout);
  (*server)->Shutdown();
  server->reset();  // the last snapshots, under the leases; then the node leaves the fleet
  std::printf("skimapd: stopped\n");
  return 0;
}
