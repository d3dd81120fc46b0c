#include "server/grpc/grpc_server.h"

#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/health_check_service_interface.h>

#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "server/core/auth/listen_address.h"
#include "server/grpc/call_observer.h"

namespace skimap::server {

absl::StatusOr<std::unique_ptr<GrpcServer>> GrpcServer::Start(const Options& options,
                                                              MapService* maps,
                                                              ObjectService* objects) {
  if (absl::Status s = CheckListenAddress(options.address,
                                          options.insecure || options.auth != nullptr, "--address");
      !s.ok()) {
    return s;
  }
  std::shared_ptr<grpc::ServerCredentials> credentials = grpc::InsecureServerCredentials();
  if (options.tls.enabled()) {
    absl::StatusOr<auth::TlsFiles::Pem> pem = options.tls.Read();
    if (!pem.ok()) return pem.status();
    grpc::SslServerCredentialsOptions ssl(
        pem->client_ca.empty() ? GRPC_SSL_DONT_REQUEST_CLIENT_CERTIFICATE
                               : GRPC_SSL_REQUEST_AND_REQUIRE_CLIENT_CERTIFICATE_AND_VERIFY);
    ssl.pem_root_certs = pem->client_ca;
    ssl.pem_key_cert_pairs.push_back({pem->key, pem->cert});
    credentials = grpc::SslServerCredentials(ssl);
  }
  grpc::EnableDefaultHealthCheckService(true);
  grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  std::unique_ptr<GrpcServer> s(new GrpcServer());
  s->grpc_objects_ = std::make_unique<GrpcObjectService>(objects, options.auth);
  GrpcMapService::Options map_service = options.map_service;
  map_service.auth = options.auth;
  s->grpc_maps_ = std::make_unique<GrpcMapService>(maps, map_service);
  grpc::ServerBuilder builder;
  // gRPC sets SO_REUSEPORT by default: a second skimapd on the same port would start and
  // take half of the connections. Fail to start instead.
  builder.AddChannelArgument(GRPC_ARG_ALLOW_REUSEPORT, 0);
  builder.AddListeningPort(options.address, credentials, &s->port_);
  builder.SetMaxReceiveMessageSize(options.max_message_bytes);
  builder.SetMaxSendMessageSize(options.max_message_bytes);
  builder.RegisterService(s->grpc_maps_.get());
  builder.RegisterService(s->grpc_objects_.get());
  for (grpc::Service* service : options.more_services) builder.RegisterService(service);
  builder.experimental().SetInterceptorCreators(MakeCallObservers(options.metrics));
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
