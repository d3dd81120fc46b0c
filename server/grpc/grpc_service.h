// GrpcMapService: the gRPC adapter of MapService (callback API). Every handler is a few
// lines: call the core, convert the status once (grpc_status.h), finish.
//
// Routes (skimap.v1.MapService): CreateMap, GetMap, ListMaps, DeleteMap, IntegrateFrame,
// UpdatePoses, GetOccupancyGrid, GetHeightMap, GetVoxels, RadiusSearch (unary);
// StreamFrames (bidi, FrameStreamReactor); StreamVoxels (server stream of GetVoxels pages);
// ExportMap (server stream) and ImportMap (client stream) of export file pieces
// (map_transfer_reactors.h), whose store work runs on the adapter's own threads;
// ListInstances, GetInstance, GetLabelVoxels (unary) and WatchInstances (server stream of
// events, instance_watch_reactor.h).
//
// Every call is authorized first when Options::auth is set (grpc_auth.h): UNAUTHENTICATED
// without a known token, PERMISSION_DENIED for a role too low or a map outside the token's
// scope; ListMaps lists only the maps in scope; StreamFrames and ImportMap check the map of
// each frame / of the first piece.
//
// Thread safety: safe for concurrent calls; no state but the core pointer and the threads
// for blocking steps.
#ifndef SERVER_GRPC_GRPC_SERVICE_H_
#define SERVER_GRPC_GRPC_SERVICE_H_

#include <grpcpp/grpcpp.h>

#include <algorithm>

#include "absl/strings/string_view.h"
#include "server/core/auth/authorizer.h"
#include "server/core/common/work_queue.h"
#include "server/core/maps/map_service.h"
#include "server/core/recognition/instance_queries.h"
#include "server/core/transfer/map_transfer.h"
#include "server/grpc/stream_limiter.h"
#include "skimap/v1/map_service.grpc.pb.h"

namespace skimap::server {

class GrpcMapService final : public v1::MapService::CallbackService {
 public:
  struct Options {
    int max_in_flight = 8;     // unacknowledged frames per StreamFrames call
    int transfer_threads = 2;  // threads for the store work of ExportMap / ImportMap
    // Open StreamFrames calls per client (peer address without port); the next one is
    // refused with RESOURCE_EXHAUSTED (stream_limiter.h). 0 = no limit.
    int max_streams_per_client = 0;
    // Who may call what (auth/authorizer.h; not owned, outlives the service); null = anyone
    // may call everything. The role each call needs: docs/operations.md.
    const auth::Authorizer* auth = nullptr;
  };
  // REQUIRES: core outlives this service; the service outlives every call it started.
  GrpcMapService(MapService* core, const Options& options)
      : core_(core),
        instances_(core),
        transfer_(core),
        options_(options),
        streams_(options.max_streams_per_client),
        blocking_({.capacity = 1, .threads = std::max(1, options.transfer_threads)}) {}

  grpc::ServerUnaryReactor* CreateMap(grpc::CallbackServerContext* ctx,
                                      const v1::CreateMapRequest* request,
                                      v1::Map* response) override;
  grpc::ServerUnaryReactor* GetMap(grpc::CallbackServerContext* ctx,
                                   const v1::GetMapRequest* request, v1::Map* response) override;
  grpc::ServerUnaryReactor* ListMaps(grpc::CallbackServerContext* ctx,
                                     const v1::ListMapsRequest* request,
                                     v1::ListMapsResponse* response) override;
  grpc::ServerUnaryReactor* DeleteMap(grpc::CallbackServerContext* ctx,
                                      const v1::DeleteMapRequest* request,
                                      v1::DeleteMapResponse* response) override;
  grpc::ServerBidiReactor<v1::Frame, v1::FrameAck>* StreamFrames(
      grpc::CallbackServerContext* ctx) override;
  grpc::ServerUnaryReactor* IntegrateFrame(grpc::CallbackServerContext* ctx,
                                           const v1::Frame* request,
                                           v1::FrameAck* response) override;
  grpc::ServerUnaryReactor* UpdatePoses(grpc::CallbackServerContext* ctx,
                                        const v1::UpdatePosesRequest* request,
                                        v1::UpdatePosesResponse* response) override;
  grpc::ServerUnaryReactor* GetOccupancyGrid(grpc::CallbackServerContext* ctx,
                                             const v1::GetOccupancyGridRequest* request,
                                             v1::OccupancyGrid* response) override;
  grpc::ServerUnaryReactor* GetHeightMap(grpc::CallbackServerContext* ctx,
                                         const v1::GetHeightMapRequest* request,
                                         v1::HeightMap* response) override;
  grpc::ServerUnaryReactor* GetVoxels(grpc::CallbackServerContext* ctx,
                                      const v1::GetVoxelsRequest* request,
                                      v1::GetVoxelsResponse* response) override;
  grpc::ServerWriteReactor<v1::GetVoxelsResponse>* StreamVoxels(
      grpc::CallbackServerContext* ctx, const v1::GetVoxelsRequest* request) override;
  grpc::ServerUnaryReactor* RadiusSearch(grpc::CallbackServerContext* ctx,
                                         const v1::RadiusSearchRequest* request,
                                         v1::RadiusSearchResponse* response) override;
  grpc::ServerWriteReactor<v1::ExportChunk>* ExportMap(
      grpc::CallbackServerContext* ctx, const v1::ExportMapRequest* request) override;
  grpc::ServerReadReactor<v1::ExportChunk>* ImportMap(grpc::CallbackServerContext* ctx,
                                                      v1::Map* response) override;
  grpc::ServerUnaryReactor* ListInstances(grpc::CallbackServerContext* ctx,
                                          const v1::ListInstancesRequest* request,
                                          v1::ListInstancesResponse* response) override;
  grpc::ServerUnaryReactor* GetInstance(grpc::CallbackServerContext* ctx,
                                        const v1::GetInstanceRequest* request,
                                        v1::Instance* response) override;
  grpc::ServerUnaryReactor* GetLabelVoxels(grpc::CallbackServerContext* ctx,
                                           const v1::GetLabelVoxelsRequest* request,
                                           v1::GetLabelVoxelsResponse* response) override;
  grpc::ServerWriteReactor<v1::InstanceEvent>* WatchInstances(
      grpc::CallbackServerContext* ctx, const v1::WatchInstancesRequest* request) override;

 private:
  // The caller's grant checked for `needed` on the map `resource` names (grpc_auth.h).
  absl::Status Allow(grpc::CallbackServerContext* ctx, auth::Role needed,
                     absl::string_view resource) const;

  MapService* const core_;
  const InstanceQueries instances_;  // the recognition calls, over core_
  const MapTransfer transfer_;       // ExportMap and ImportMap, over core_
  const Options options_;
  StreamLimiter streams_;
  WorkQueue blocking_;  // ExportMap / ImportMap steps (unbounded: one step per open call)
};

}  // namespace skimap::server

#endif  // SERVER_GRPC_GRPC_SERVICE_H_
