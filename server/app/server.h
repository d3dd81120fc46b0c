// Server: skimapd's composition root. It owns, in this order, the fleet membership (with
// --store=postgresql://...), the map store, the ObjectService and MapService cores, and
// the adapters that serve them: gRPC (grpc/grpc_server.h) and HTTP/REST
// (http/http_server.h). The adapters hold references to the cores, never the cores
// themselves, so both transports call the same methods with the same validation.
//
//   Server::Options options;
//   options.grpc.address = "127.0.0.1:0";
//   options.http.address = "127.0.0.1:0";           // "" = no HTTP adapter
//   absl::StatusOr<std::unique_ptr<Server>> server = Server::Start(options);
//   (*server)->grpc_port(); (*server)->http_port();
//   (*server)->maps().SnapshotAll();
//   server->reset();   // adapters stop, cores drain and snapshot, the fleet node leaves
//
// Thread safety: Shutdown may be called from any thread and is idempotent; the cores are
// thread safe.
#ifndef SERVER_APP_SERVER_H_
#define SERVER_APP_SERVER_H_

#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "server/core/auth/authorizer.h"
#include "server/core/fleet/fleet.h"
#include "server/core/maps/map_service.h"
#include "server/core/metrics/metrics.h"
#include "server/core/objects/object_service.h"
#include "server/grpc/fleet_grpc_service.h"
#include "server/grpc/grpc_server.h"
#include "server/http/http_server.h"
#include "server/http/map_events.h"
#include "storage/map_store.h"

namespace skimap::server {

class Server {
 public:
  struct Options {
    // The map service core. Its store, classifier and ownership are wired here;
    // max_reply_bytes is capped at grpc.max_message_bytes.
    MapService::Options maps;
    // The object service; objects.db_path "" keeps its database in memory only.
    ObjectService::Options objects;
    // SQLite file where maps persist (skimapd: DATA_DIR/maps.sqlite): every frame and pose
    // update is journaled before its ack and the maps are reloaded at start. "" keeps maps
    // in memory only.
    std::string maps_db_path;
    // Or a store the caller owns (outlives the server), e.g. a test's fault-injecting
    // wrapper; takes precedence over maps_db_path.
    storage::MapStore* map_store = nullptr;
    // A node of a fleet (docs/architecture.md, "The fleet"): with a PostgreSQL URL, maps
    // persist there under leases and this server joins the fleet as a new node; takes
    // precedence over map_store and maps_db_path.
    struct FleetOptions {
      std::string store_url;          // "" = a single server
      std::string advertise_address;  // where others reach this node; "" = grpc.address
      absl::Duration lease_ttl = absl::Seconds(6);
      // What an acknowledgement means: "standby" (on the primary and a synchronous
      // standby: the store refuses a primary not configured for it and holds appends while
      // none is attached), "primary" (the primary's disk), "auto" (standby when store_url
      // lists several hosts).
      std::string durability = "auto";
      // How long a store call reconnects, and an append waits for a standby, before it
      // answers Unavailable.
      absl::Duration failover_timeout = absl::Seconds(30);
      // A store statement without an answer for this long costs its connection.
      absl::Duration statement_timeout = absl::Seconds(5);
    };
    FleetOptions fleet;
    GrpcServer::Options grpc;
    // The REST adapter; http.address "" = none. http.web_root: the viewer's files.
    HttpServer::Options http = {.address = ""};
    // The viewer's live updates (GET /v1/maps/{map}/events).
    MapEvents::Options events;
    // GET /metrics (Prometheus text, on the REST adapter) answers without a token when
    // authentication is configured (skimapd --metrics_public); false: it takes a token
    // like the other routes. The route exists whenever HTTP is on.
    bool metrics_public = true;
    // Bearer tokens (server/core/auth/token_file.h) for both adapters; "" = no authentication (then
    // only loopback addresses, or `insecure`). With tokens, any address may be bound. TLS:
    // grpc.tls and http.tls.
    std::string auth_tokens_file;
  };

  // Reads the token file, checks both listen addresses, joins the fleet, opens the store, builds
  // the cores (loading the stored maps and objects), then starts the adapters. The first error: the
  // token file's error, FailedPrecondition for an address beyond loopback without `insecure` or
  // tokens, the store's or the object database's, Unavailable for an address that cannot be bound.
  static absl::StatusOr<std::unique_ptr<Server>> Start(const Options& options);
  // Shutdown(), then the cores are drained and snapshot, then the fleet node leaves.
  ~Server();

  int grpc_port() const { return grpc_->port(); }
  int http_port() const { return http_ ? http_->port() : 0; }  // 0 without HTTP
  MapService& maps() { return *maps_; }
  ObjectService& objects() { return *objects_; }
  // The HTTP adapter (its route table), or null without HTTP.
  const HttpServer* http() const { return http_.get(); }
  // The Prometheus instruments the cores and adapters report to (GET /metrics).
  Metrics& metrics() { return *metrics_; }
  // The fleet membership, or null on a single server.
  Fleet* fleet() { return fleet_.get(); }
  // Reads the token file again (skimapd on SIGHUP): OK, or the error (naming the file and
  // line, never a token) and the previous tokens stay. FailedPrecondition without tokens.
  [[nodiscard]] absl::Status ReloadTokens();

  // Stops both adapters: no new requests; event streams end at once; open gRPC calls are
  // cancelled after `grace`.
  void Shutdown(absl::Duration grace = absl::Seconds(2));

 private:
  Server() = default;

  // Declared in dependency order: destroyed from the adapters up to the fleet.
  std::unique_ptr<Metrics> metrics_;          // outlives everything that reports to it
  std::unique_ptr<auth::Authorizer> auth_;    // outlives the adapters; null without tokens
  std::unique_ptr<Fleet> fleet_;              // outlives the store it holds and the cores
  std::unique_ptr<storage::MapStore> store_;  // outlives the cores
  std::unique_ptr<ObjectService> objects_;    // outlives maps_: maps ask it for the classifier
  std::unique_ptr<MapService> maps_;
  std::unique_ptr<GrpcFleetService> fleet_service_;  // null on a single server
  std::unique_ptr<GrpcServer> grpc_;
  std::unique_ptr<MapEvents> events_;  // outlives http_, whose routes use it
  std::unique_ptr<HttpServer> http_;
};

}  // namespace skimap::server

#endif  // SERVER_APP_SERVER_H_
