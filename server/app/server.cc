#include "server/app/server.h"

#include <algorithm>
#include <cstdio>

#include "absl/strings/str_cat.h"
#include "server/core/auth/listen_address.h"
#include "server/http/rest_routes.h"
#include "storage/postgres.h"
#include "storage/sqlite_map_store.h"

namespace skimap::server {

absl::StatusOr<std::unique_ptr<Server>> Server::Start(const Options& options) {
  std::unique_ptr<auth::Authorizer> authorizer;
  if (!options.auth_tokens_file.empty()) {
    absl::StatusOr<std::unique_ptr<auth::Authorizer>> opened =
        auth::Authorizer::Open(options.auth_tokens_file);
    if (!opened.ok()) return opened.status();
    authorizer = *std::move(opened);
  }
  // Refuse a wrong address before anything is loaded or joined.
  const bool authenticated = authorizer != nullptr;
  if (absl::Status s = CheckListenAddress(options.grpc.address,
                                          options.grpc.insecure || authenticated, "--address");
      !s.ok()) {
    return s;
  }
  if (!options.http.address.empty()) {
    if (absl::Status s = CheckListenAddress(
            options.http.address, options.http.insecure || authenticated, "--http_address");
        !s.ok()) {
      return s;
    }
  }
  std::unique_ptr<Server> s(new Server());
  s->metrics_ = std::make_unique<Metrics>();
  s->auth_ = std::move(authorizer);
  MapService::Options maps = options.maps;
  maps.metrics = s->metrics_.get();
  GrpcServer::Options grpc = options.grpc;
  grpc.metrics = s->metrics_.get();
  grpc.auth = s->auth_.get();
  if (!options.fleet.store_url.empty()) {
    const std::string& advertise = options.fleet.advertise_address;
    const std::string& durability = options.fleet.durability;
    if (durability != "auto" && durability != "standby" && durability != "primary") {
      return absl::InvalidArgumentError(
          absl::StrCat("--store_durability: '", durability, "' is not auto, standby or primary"));
    }
    absl::StatusOr<std::unique_ptr<Fleet>> fleet = Fleet::Open(
        options.fleet.store_url,
        {.address = advertise.empty() ? grpc.address : advertise,
         .lease_ttl = options.fleet.lease_ttl},
        {.failover_timeout = options.fleet.failover_timeout,
         .statement_timeout = options.fleet.statement_timeout,
         .require_synchronous_standby =
             durability == "standby" ||
             (durability == "auto" && storage::PgHostCount(options.fleet.store_url) > 1)});
    if (!fleet.ok()) {
      return absl::Status(fleet.status().code(),
                          absl::StrCat("--store: ", fleet.status().message()));
    }
    s->fleet_ = *std::move(fleet);
    maps.store = &s->fleet_->store();
    maps.ownership = &s->fleet_->node();
    s->fleet_service_ = std::make_unique<GrpcFleetService>(&s->fleet_->node());
    s->fleet_service_->RequireAuth(s->auth_.get());
    grpc.more_services.push_back(s->fleet_service_.get());
  } else if (options.map_store != nullptr) {
    maps.store = options.map_store;
  } else if (!options.maps_db_path.empty()) {
    absl::StatusOr<std::unique_ptr<storage::SqliteMapStore>> store =
        storage::SqliteMapStore::Open(options.maps_db_path);
    if (!store.ok()) {
      return absl::Status(store.status().code(),
                          absl::StrCat(options.maps_db_path, ": ", store.status().message()));
    }
    s->store_ = *std::move(store);
    maps.store = s->store_.get();
  }
  maps.max_reply_bytes = std::min<size_t>(maps.max_reply_bytes, grpc.max_message_bytes);
  // Objects first: maps with recognition take the classifier when they load.
  absl::StatusOr<std::unique_ptr<ObjectService>> objects = ObjectService::Create(options.objects);
  if (!objects.ok()) return objects.status();
  s->objects_ = *std::move(objects);
  ObjectRegistry* registry = &s->objects_->registry();
  maps.classifier = [registry] { return registry->classifier(); };
  s->maps_ = std::make_unique<MapService>(maps);
  if (absl::Status recovered = s->maps_->Recover(); !recovered.ok()) return recovered;
  s->metrics_->SetMapGaugeSource([m = s->maps_.get()] { return m->MetricGauges(); });
  if (s->fleet_ != nullptr) {
    s->metrics_->SetStoreGaugeSource([store = &s->fleet_->store()] {
      const storage::PostgresMapStore::Health h = store->health();
      return Metrics::StoreGauges{.reconnects = h.reconnects,
                                  .unknown_commits = h.unknown_commits,
                                  .unknown_committed = h.unknown_committed,
                                  .unknown_not_committed = h.unknown_not_committed,
                                  .unknown_unresolved = h.unknown_unresolved,
                                  .standby_waits = h.standby_waits,
                                  .synchronous = h.synchronous};
    });
  }

  absl::StatusOr<std::unique_ptr<GrpcServer>> grpc_server =
      GrpcServer::Start(grpc, s->maps_.get(), s->objects_.get());
  if (!grpc_server.ok()) return grpc_server.status();
  s->grpc_ = *std::move(grpc_server);
  if (!options.http.address.empty()) {
    s->events_ = std::make_unique<MapEvents>(*s->maps_, options.events);
    std::vector<RestRoute> routes = MakeRestRoutes(*s->maps_, *s->objects_, *s->events_);
    routes.push_back(MetricsRoute(*s->metrics_));
    HttpServer::Options http_options = options.http;
    http_options.metrics = s->metrics_.get();
    http_options.auth = s->auth_.get();
    http_options.metrics_public = options.metrics_public;
    absl::StatusOr<std::unique_ptr<HttpServer>> http =
        HttpServer::Start(http_options, std::move(routes));
    if (!http.ok()) return http.status();
    s->http_ = *std::move(http);
  }
  return s;
}

absl::Status Server::ReloadTokens() {
  if (auth_ == nullptr) {
    return absl::FailedPreconditionError("no token file to reload (skimapd --auth_tokens_file)");
  }
  return auth_->Reload();
}

void Server::Shutdown(absl::Duration grace) {
  if (events_ != nullptr) events_->Stop();  // first: a stream holds an HTTP thread
  if (http_ != nullptr) http_->Stop();
  if (grpc_ != nullptr) grpc_->Shutdown(grace);
}

Server::~Server() {
  Shutdown();
  http_.reset();
  events_.reset();
  grpc_.reset();
  maps_.reset();  // drains the map workers and writes the last snapshots, under the leases
  objects_.reset();
  store_.reset();
  if (fleet_ != nullptr) {
    if (absl::Status s = fleet_->node().Leave(); !s.ok()) {
      std::fprintf(stderr, "skimapd: leaving the fleet: %s\n", s.ToString().c_str());
    }
  }
}

}  // namespace skimap::server
