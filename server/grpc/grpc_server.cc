#include "server/grpc/grpc_server.h"

#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/health_check_service_interface.h>

#include <algorithm>

#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "server/listen_address.h"
#include "storage/sqlite_map_store.h"

namespace skimap::server {

absl::StatusOr<std::unique_ptr<GrpcServer>> GrpcServer::Start(const Options& options) {
  if (!options.insecure && !IsLoopbackAddress(options.address)) {
    return absl::FailedPreconditionError(absl::StrCat(
        "address ", options.address,
        " listens beyond loopback and skimapd has no authentication yet; pass --insecure to "
        "allow anyone who reaches the port to read and write every map"));
  }
  grpc::EnableDefaultHealthCheckService(true);
  grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  std::unique_ptr<GrpcServer> s(new GrpcServer());
  MapService::Options service = options.service;
  if (options.map_store != nullptr) {
    service.store = options.map_store;
  } else if (!options.maps_db_path.empty()) {
    absl::StatusOr<std::unique_ptr<storage::SqliteMapStore>> store =
        storage::SqliteMapStore::Open(options.maps_db_path);
    if (!store.ok()) {
      return absl::Status(store.status().code(),
                          absl::StrCat(options.maps_db_path, ": ", store.status().message()));
    }
    s->store_ = *std::move(store);
    service.store = s->store_.get();
  }
  service.max_reply_bytes = std::min<size_t>(service.max_reply_bytes, options.max_message_bytes);
  // Objects first: maps with recognition take the classifier when they load.
  absl::StatusOr<std::unique_ptr<ObjectService>> objects = ObjectService::Create(options.objects);
  if (!objects.ok()) return objects.status();
  s->objects_ = *std::move(objects);
  s->grpc_objects_ = std::make_unique<GrpcObjectService>(s->objects_.get());
  ObjectRegistry* registry = &s->objects_->registry();
  service.classifier = [registry] { return registry->classifier(); };
  s->core_ = std::make_unique<MapService>(service);
  if (absl::Status recovered = s->core_->Recover(); !recovered.ok()) return recovered;
  s->grpc_service_ = std::make_unique<GrpcMapService>(s->core_.get(), options.grpc);
  grpc::ServerBuilder builder;
  // gRPC sets SO_REUSEPORT by default: a second skimapd on the same port would start and
  // take half of the connections. Fail to start instead.
  builder.AddChannelArgument(GRPC_ARG_ALLOW_REUSEPORT, 0);
  builder.AddListeningPort(options.address, grpc::InsecureServerCredentials(), &s->port_);
  builder.SetMaxReceiveMessageSize(options.max_message_bytes);
  builder.SetMaxSendMessageSize(options.max_message_bytes);
  builder.RegisterService(s->grpc_service_.get());
  builder.RegisterService(s->grpc_objects_.get());
  for (grpc::Service* service : options.more_services) builder.RegisterService(service);
  s->server_ = builder.BuildAndStart();
  if (s->server_ == nullptr || s->port_ == 0) {
    return absl::UnavailableError(absl::StrCat("cannot listen on ", options.address));
  }
  // Health answers per service too ("" is the whole server, SERVING by default).
  grpc::HealthCheckServiceInterface* health = s->server_->GetHealthCheckService();
  for (const char* service : {"skimap.v1.MapService", "skimap.v1.ObjectService"}) {
    health->SetServingStatus(service, true);
  }
  return s;
}

GrpcServer::~GrpcServer() { Shutdown(); }

void GrpcServer::Shutdown(absl::Duration grace) {
  if (server_ != nullptr) server_->Shutdown(absl::ToChronoTime(absl::Now() + grace));
}

}  // namespace skimap::server
