#include "server/grpc/call_observer.h"

#include <google/protobuf/descriptor.h>
#include <google/protobuf/message.h>

#include <string>

#include "absl/strings/match.h"
#include "absl/time/clock.h"
#include "server/core/logging/log.h"
#include "server/core/logging/request_context.h"

namespace skimap::server {
namespace {

using grpc::experimental::InterceptionHookPoints;
using grpc::experimental::InterceptorBatchMethods;
using grpc::experimental::ServerRpcInfo;

// The method as a label: "skimap.v1.MapService/GetMap"; "other" outside the services skimapd
// serves (an unknown method must not grow the label set).
std::string MethodLabel(const char* method) {
  absl::string_view m = method == nullptr ? "" : method;
  if (absl::StartsWith(m, "/")) m.remove_prefix(1);
  if (absl::StartsWith(m, "skimap.v1.") || absl::StartsWith(m, "grpc.")) return std::string(m);
  return "other";
}

// The map a request names (its `map` field, a `name` of the form "maps/...", or the
// `map_id` of CreateMap), capped.
std::string MapOf(const google::protobuf::Message& request) {
  const google::protobuf::Descriptor* d = request.GetDescriptor();
  const google::protobuf::Reflection* r = request.GetReflection();
  for (const char* field : {"map", "name", "map_id"}) {
    const google::protobuf::FieldDescriptor* f = d->FindFieldByName(field);
    if (f == nullptr || f->is_repeated() ||
        f->type() != google::protobuf::FieldDescriptor::TYPE_STRING) {
      continue;
    }
    const std::string value = r->GetString(request, f);
    if (std::string_view(field) == "name" && !absl::StartsWith(value, "maps/")) continue;
    if (std::string_view(field) == "map_id") return "maps/" + value.substr(0, 256);
    return value.substr(0, 256);
  }
  return "";
}

class CallObserver final : public grpc::experimental::Interceptor {
 public:
  CallObserver(ServerRpcInfo* info, Metrics* metrics)
      : metrics_(metrics),
        start_(absl::Now()),
        method_(MethodLabel(info->method())),
        single_request_(info->type() == ServerRpcInfo::Type::UNARY ||
                        info->type() == ServerRpcInfo::Type::SERVER_STREAMING) {}

  ~CallObserver() override {
    if (!done_) Done(static_cast<int>(grpc::StatusCode::CANCELLED));  // no status was sent
  }

  void Intercept(InterceptorBatchMethods* methods) override {
    if (methods->QueryInterceptionHookPoint(InterceptionHookPoints::POST_RECV_INITIAL_METADATA)) {
      std::string given;
      const auto* metadata = methods->GetRecvInitialMetadata();
      if (auto it = metadata->find("x-request-id"); it != metadata->end()) {
        given.assign(it->second.data(), it->second.size());
      }
      context_ = std::make_shared<RequestContext>(
          RequestContext{.id = RequestIdFrom(given), .method = method_});
    }
    if (single_request_ &&
        methods->QueryInterceptionHookPoint(InterceptionHookPoints::POST_RECV_MESSAGE)) {
      // skimapd's own services are protobuf services: the received message is one.
      if (absl::StartsWith(method_, "skimap.v1.") && methods->GetRecvMessage() != nullptr) {
        map_ = MapOf(*static_cast<const google::protobuf::Message*>(methods->GetRecvMessage()));
      }
    }
    if (methods->QueryInterceptionHookPoint(InterceptionHookPoints::PRE_SEND_STATUS) && !done_) {
      if (context_ != nullptr) {
        methods->GetSendTrailingMetadata()->emplace("x-request-id", context_->id);
      }
      Done(static_cast<int>(methods->GetSendStatus().error_code()));
    }
    // The handler (and the callbacks gRPC runs from this batch) see the call's context.
    ScopedRequest scope(context_);
    methods->Proceed();
  }

 private:
  void Done(int code) {
    done_ = true;
    const absl::Duration latency = absl::Now() - start_;
    if (metrics_ != nullptr) metrics_->GrpcCallDone(method_, code, latency);
    ScopedRequest scope(context_);
    Log({.level = LogLevel::kInfo,
         .msg = "call",
         .map = map_,
         .code = code,
         .latency = latency,
         .access = true});
  }

  Metrics* const metrics_;
  const absl::Time start_;
  const std::string method_;
  const bool single_request_;
  std::shared_ptr<const RequestContext> context_;
  std::string map_;
  bool done_ = false;
};

class CallObserverFactory final : public grpc::experimental::ServerInterceptorFactoryInterface {
 public:
  explicit CallObserverFactory(Metrics* metrics) : metrics_(metrics) {}
  grpc::experimental::Interceptor* CreateServerInterceptor(ServerRpcInfo* info) override {
    return new CallObserver(info, metrics_);
  }

 private:
  Metrics* const metrics_;
};

}  // namespace

std::vector<std::unique_ptr<grpc::experimental::ServerInterceptorFactoryInterface>>
MakeCallObservers(Metrics* metrics) {
  std::vector<std::unique_ptr<grpc::experimental::ServerInterceptorFactoryInterface>> out;
  out.push_back(std::make_unique<CallObserverFactory>(metrics));
  return out;
}

}  // namespace skimap::server
