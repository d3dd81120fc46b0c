#include "server/grpc/grpc_service.h"

#include <memory>
#include <utility>

#include "server/core/auth/access.h"
#include "server/grpc/frame_stream_reactor.h"
#include "server/grpc/grpc_auth.h"
#include "server/grpc/grpc_status.h"
#include "server/grpc/instance_watch_reactor.h"
#include "server/grpc/map_transfer_reactors.h"

namespace skimap::server {
namespace {

using auth::Role;
using grpc::CallbackServerContext;
using grpc::ServerUnaryReactor;

// StreamVoxels: one GetVoxels page per write until the last page.
class VoxelPageWriter final : public grpc::ServerWriteReactor<v1::GetVoxelsResponse> {
 public:
  VoxelPageWriter(const MapService* core, const v1::GetVoxelsRequest& request)
      : core_(core), request_(request) {
    NextPage();
  }
  void OnWriteDone(bool ok) override {
    if (!ok) return Finish(grpc::Status(grpc::StatusCode::CANCELLED, "client went away"));
    if (request_.page_token().empty()) return Finish(grpc::Status::OK);
    NextPage();
  }
  void OnDone() override { delete this; }

 private:
  void NextPage() {
    absl::StatusOr<v1::GetVoxelsResponse> page = core_->GetVoxels(request_);
    if (!page.ok()) return Finish(ToGrpcStatus(page.status()));
    page_ = *std::move(page);
    request_.set_page_token(page_.next_page_token());
    StartWrite(&page_);
  }

  const MapService* const core_;
  v1::GetVoxelsRequest request_;  // page_token advances
  v1::GetVoxelsResponse page_;
};

}  // namespace

absl::Status GrpcMapService::Allow(CallbackServerContext* ctx, Role needed,
                                   absl::string_view resource) const {
  return CheckMapCall(options_.auth, ctx, needed, resource).status();
}

ServerUnaryReactor* GrpcMapService::CreateMap(CallbackServerContext* ctx,
                                              const v1::CreateMapRequest* request,
                                              v1::Map* response) {
  if (absl::Status s =
          Allow(ctx, auth::MethodRole("MapService/CreateMap"), "maps/" + request->map_id());
      !s.ok())
    return Refuse(ctx, s);
  return Reply(ctx, core_->CreateMap(*request), response);
}

ServerUnaryReactor* GrpcMapService::GetMap(CallbackServerContext* ctx,
                                           const v1::GetMapRequest* request, v1::Map* response) {
  if (absl::Status s = Allow(ctx, auth::MethodRole("MapService/GetMap"), request->name()); !s.ok())
    return Refuse(ctx, s);
  return Reply(ctx, core_->GetMap(*request), response);
}

ServerUnaryReactor* GrpcMapService::ListMaps(CallbackServerContext* ctx,
                                             const v1::ListMapsRequest* request,
                                             v1::ListMapsResponse* response) {
  absl::StatusOr<auth::Grant> grant =
      CheckCall(options_.auth, ctx, auth::MethodRole("MapService/ListMaps"));
  if (!grant.ok()) return Refuse(ctx, grant.status());
  absl::StatusOr<v1::ListMapsResponse> maps = core_->ListMaps(*request);
  if (maps.ok()) auth::KeepMapsInScope(*grant, &*maps);
  return Reply(ctx, std::move(maps), response);
}

ServerUnaryReactor* GrpcMapService::DeleteMap(CallbackServerContext* ctx,
                                              const v1::DeleteMapRequest* request,
                                              v1::DeleteMapResponse* response) {
  if (absl::Status s = Allow(ctx, auth::MethodRole("MapService/DeleteMap"), request->name());
      !s.ok())
    return Refuse(ctx, s);
  ServerUnaryReactor* reactor = ctx->DefaultReactor();
  reactor->Finish(ToGrpcStatus(core_->DeleteMap(*request)));
  return reactor;
}

grpc::ServerBidiReactor<v1::Frame, v1::FrameAck>* GrpcMapService::StreamFrames(
    CallbackServerContext* ctx) {
  absl::StatusOr<auth::Grant> grant =
      CheckCall(options_.auth, ctx, auth::MethodRole("MapService/StreamFrames"));
  if (!grant.ok())
    return new RefusedCall<grpc::ServerBidiReactor<v1::Frame, v1::FrameAck>>(grant.status());
  absl::StatusOr<StreamLimiter::Slot> slot = streams_.Acquire(ctx->peer());
  if (!slot.ok())
    return new RefusedCall<grpc::ServerBidiReactor<v1::Frame, v1::FrameAck>>(slot.status());
  return new FrameStreamReactor(core_, options_.max_in_flight, *std::move(slot), *std::move(grant));
}

ServerUnaryReactor* GrpcMapService::IntegrateFrame(CallbackServerContext* ctx,
                                                   const v1::Frame* request,
                                                   v1::FrameAck* response) {
  if (absl::Status s = Allow(ctx, auth::MethodRole("MapService/IntegrateFrame"), request->map());
      !s.ok())
    return Refuse(ctx, s);
  ServerUnaryReactor* reactor = ctx->DefaultReactor();
  core_->IntegrateFrame(std::make_shared<v1::Frame>(*request),
                        [reactor, response](absl::StatusOr<v1::FrameAck> ack) {
                          if (ack.ok()) *response = *std::move(ack);
                          reactor->Finish(ToGrpcStatus(ack.status()));
                        });
  return reactor;
}

ServerUnaryReactor* GrpcMapService::UpdatePoses(CallbackServerContext* ctx,
                                                const v1::UpdatePosesRequest* request,
                                                v1::UpdatePosesResponse* response) {
  if (absl::Status s = Allow(ctx, auth::MethodRole("MapService/UpdatePoses"), request->map());
      !s.ok())
    return Refuse(ctx, s);
  ServerUnaryReactor* reactor = ctx->DefaultReactor();
  core_->UpdatePoses(std::make_shared<v1::UpdatePosesRequest>(*request),
                     [reactor, response](absl::StatusOr<v1::UpdatePosesResponse> r) {
                       if (r.ok()) *response = *std::move(r);
                       reactor->Finish(ToGrpcStatus(r.status()));
                     });
  return reactor;
}

ServerUnaryReactor* GrpcMapService::GetOccupancyGrid(CallbackServerContext* ctx,
                                                     const v1::GetOccupancyGridRequest* request,
                                                     v1::OccupancyGrid* response) {
  if (absl::Status s = Allow(ctx, auth::MethodRole("MapService/GetOccupancyGrid"), request->map());
      !s.ok())
    return Refuse(ctx, s);
  return Reply(ctx, core_->GetOccupancyGrid(*request), response);
}

ServerUnaryReactor* GrpcMapService::GetHeightMap(CallbackServerContext* ctx,
                                                 const v1::GetHeightMapRequest* request,
                                                 v1::HeightMap* response) {
  if (absl::Status s = Allow(ctx, auth::MethodRole("MapService/GetHeightMap"), request->map());
      !s.ok())
    return Refuse(ctx, s);
  return Reply(ctx, core_->GetHeightMap(*request), response);
}

ServerUnaryReactor* GrpcMapService::GetVoxels(CallbackServerContext* ctx,
                                              const v1::GetVoxelsRequest* request,
                                              v1::GetVoxelsResponse* response) {
  if (absl::Status s = Allow(ctx, auth::MethodRole("MapService/GetVoxels"), request->map());
      !s.ok())
    return Refuse(ctx, s);
  return Reply(ctx, core_->GetVoxels(*request), response);
}

grpc::ServerWriteReactor<v1::GetVoxelsResponse>* GrpcMapService::StreamVoxels(
    CallbackServerContext* ctx, const v1::GetVoxelsRequest* request) {
  if (absl::Status s = Allow(ctx, auth::MethodRole("MapService/StreamVoxels"), request->map());
      !s.ok()) {
    return new RefusedCall<grpc::ServerWriteReactor<v1::GetVoxelsResponse>>(s);
  }
  return new VoxelPageWriter(core_, *request);
}

ServerUnaryReactor* GrpcMapService::RadiusSearch(CallbackServerContext* ctx,
                                                 const v1::RadiusSearchRequest* request,
                                                 v1::RadiusSearchResponse* response) {
  if (absl::Status s = Allow(ctx, auth::MethodRole("MapService/RadiusSearch"), request->map());
      !s.ok())
    return Refuse(ctx, s);
  return Reply(ctx, core_->RadiusSearch(*request), response);
}

grpc::ServerWriteReactor<v1::ExportChunk>* GrpcMapService::ExportMap(
    CallbackServerContext* ctx, const v1::ExportMapRequest* request) {
  if (absl::Status s = Allow(ctx, auth::MethodRole("MapService/ExportMap"), request->name());
      !s.ok()) {
    return new RefusedCall<grpc::ServerWriteReactor<v1::ExportChunk>>(s);
  }
  return new ExportWriteReactor(&transfer_, &blocking_, *request);
}

grpc::ServerReadReactor<v1::ExportChunk>* GrpcMapService::ImportMap(CallbackServerContext* ctx,
                                                                    v1::Map* response) {
  absl::StatusOr<auth::Grant> grant =
      CheckCall(options_.auth, ctx, auth::MethodRole("MapService/ImportMap"));
  if (!grant.ok()) return new RefusedCall<grpc::ServerReadReactor<v1::ExportChunk>>(grant.status());
  return new ImportReadReactor(&transfer_, &blocking_, ctx, response, *std::move(grant));
}

ServerUnaryReactor* GrpcMapService::ListInstances(CallbackServerContext* ctx,
                                                  const v1::ListInstancesRequest* request,
                                                  v1::ListInstancesResponse* response) {
  if (absl::Status s = Allow(ctx, auth::MethodRole("MapService/ListInstances"), request->map());
      !s.ok())
    return Refuse(ctx, s);
  return Reply(ctx, instances_.ListInstances(*request), response);
}

ServerUnaryReactor* GrpcMapService::GetInstance(CallbackServerContext* ctx,
                                                const v1::GetInstanceRequest* request,
                                                v1::Instance* response) {
  if (absl::Status s = Allow(ctx, auth::MethodRole("MapService/GetInstance"), request->name());
      !s.ok())
    return Refuse(ctx, s);
  return Reply(ctx, instances_.GetInstance(*request), response);
}

ServerUnaryReactor* GrpcMapService::GetLabelVoxels(CallbackServerContext* ctx,
                                                   const v1::GetLabelVoxelsRequest* request,
                                                   v1::GetLabelVoxelsResponse* response) {
  if (absl::Status s = Allow(ctx, auth::MethodRole("MapService/GetLabelVoxels"), request->map());
      !s.ok())
    return Refuse(ctx, s);
  return Reply(ctx, instances_.GetLabelVoxels(*request), response);
}

grpc::ServerWriteReactor<v1::InstanceEvent>* GrpcMapService::WatchInstances(
    CallbackServerContext* ctx, const v1::WatchInstancesRequest* request) {
  if (absl::Status s = Allow(ctx, auth::MethodRole("MapService/WatchInstances"), request->map());
      !s.ok()) {
    return new RefusedCall<grpc::ServerWriteReactor<v1::InstanceEvent>>(s);
  }
  return new InstanceWatchReactor(&instances_, *request);
}

}  // namespace skimap::server
