// MapClient: the C++ client of skimap.v1.MapService (what the `skimap` CLI uses).
//
//   absl::StatusOr<std::unique_ptr<MapClient>> client = MapClient::Connect("localhost:50051");
//   (*client)->CreateMap(request);
//   std::unique_ptr<FrameStream> stream = (*client)->OpenFrameStream({.window = 8});
//   stream->Send(frame);             // blocks while `window` frames are unacknowledged
//   absl::StatusOr<std::vector<v1::FrameAck>> acks = stream->Finish();
//
// Errors come back as absl::Status with the server's code and message.
//
// Fleets (several skimapd nodes on one store): a node answers a request for a map that
// another node serves with UNAVAILABLE and a MapRedirect in the status details; the unary
// calls, StreamVoxels and ExportMap follow it to the owner (up to max_redirects hops) and
// remember each map's owner for the next calls. StreamFrames acks carry the redirect
// (FrameAck.redirect): StreamTo() gives a client for that address.
//
// Thread safety: MapClient is thread safe (one channel, any number of concurrent calls).
// A FrameStream is used by one thread at a time.
#ifndef CLIENT_MAP_CLIENT_H_
#define CLIENT_MAP_CLIENT_H_

#include <grpcpp/grpcpp.h>

#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "client/channel.h"
#include "client/frame_stream.h"
#include "skimap/v1/fleet.grpc.pb.h"
#include "skimap/v1/map_service.grpc.pb.h"

namespace skimap::client {

class MapClient {
 public:
  struct Options {
    int max_message_bytes = 80 << 20;                     // match skimapd's --max_message_mb
    absl::Duration timeout = absl::Seconds(60);           // deadline of each unary call
    absl::Duration transfer_timeout = absl::Minutes(30);  // ExportMap / ImportMap calls
    int max_redirects = 3;  // fleet redirects followed per call; 0 = report them
    // TLS and the bearer token (channel.h), also used for the nodes redirects lead to.
    Connection connection;
  };
  // Creates a channel to `target` (host:port); does not wait for the server.
  static std::unique_ptr<MapClient> Connect(const std::string& target, const Options& options);
  static std::unique_ptr<MapClient> Connect(const std::string& target) {
    return Connect(target, Options{});
  }
  // Waits up to `timeout` for the channel to connect; Unavailable otherwise.
  absl::Status WaitForServer(absl::Duration timeout);
  // grpc.health.v1.Health/Check of the whole server (no token needed): OK when it answers
  // SERVING, Unavailable naming the status it answered otherwise, or the call's error.
  absl::Status CheckHealth();

  absl::StatusOr<v1::Map> CreateMap(const v1::CreateMapRequest& request);
  absl::StatusOr<v1::Map> GetMap(const std::string& name);
  // Every map, following page tokens.
  absl::StatusOr<std::vector<v1::Map>> ListAllMaps();
  absl::StatusOr<v1::ListMapsResponse> ListMaps(const v1::ListMapsRequest& request);
  absl::Status DeleteMap(const std::string& name);

  absl::StatusOr<v1::FrameAck> IntegrateFrame(const v1::Frame& frame);
  absl::StatusOr<v1::UpdatePosesResponse> UpdatePoses(const v1::UpdatePosesRequest& request);
  // Opens a StreamFrames call, to the node that served map `map` ("maps/ID") last when
  // known (a fleet), else to this client's target.
  std::unique_ptr<FrameStream> OpenFrameStream(const FrameStream::Options& options,
                                               const std::string& map = "");

  // The grid with raw data (width*height bytes), whatever data_encoding `r` asked the
  // server for (GRID_ENCODING_ZSTD is decompressed here; DataLoss if it does not decode).
  absl::StatusOr<v1::OccupancyGrid> GetOccupancyGrid(const v1::GetOccupancyGridRequest& r);
  absl::StatusOr<v1::HeightMap> GetHeightMap(const v1::GetHeightMapRequest& request);
  absl::StatusOr<v1::GetVoxelsResponse> GetVoxels(const v1::GetVoxelsRequest& request);
  // Every voxel of the request's box, via StreamVoxels.
  absl::StatusOr<std::vector<v1::Voxel>> GetAllVoxels(const v1::GetVoxelsRequest& request);
  absl::StatusOr<v1::RadiusSearchResponse> RadiusSearch(const v1::RadiusSearchRequest& r);
  // Every instance the request selects, following page tokens (the request's page_token
  // is where the listing starts).
  absl::StatusOr<std::vector<v1::Instance>> ListAllInstances(v1::ListInstancesRequest request);

  // ExportMap: hands the pieces of the map's export file to `sink`, in order, as they
  // arrive (nothing is buffered here). An error of `sink` cancels the call and is returned;
  // otherwise the call's status.
  absl::Status ExportMap(const v1::ExportMapRequest& request,
                         const std::function<absl::Status(std::string_view piece)>& sink);
  // ImportMap: sends the pieces `source` returns until it returns an empty string (the end
  // of the file), the first one with `map_id` ("" keeps the file's id); the new map. An
  // error of `source` cancels the call (the server then keeps nothing) and is returned.
  absl::StatusOr<v1::Map> ImportMap(const std::string& map_id,
                                    const std::function<absl::StatusOr<std::string>()>& source);

  // FleetService.ListNodes of the node this client connects to. FailedPrecondition from
  // a server that is not a fleet node.
  absl::StatusOr<v1::ListNodesResponse> ListNodes();

  v1::MapService::Stub& stub() { return *stub_; }
  const Options& options() const { return options_; }
  const std::string& target() const { return target_; }

 private:
  MapClient(const std::string& target, const Options& options);
  void SetDeadline(grpc::ClientContext* ctx) const;
  // The stub for the node that served map `name` last (this client's target if none).
  v1::MapService::Stub* StubForMap(const std::string& name);
  // Follows `status`'s redirect, if any, within the hop budget: the owner's stub (and the
  // map remembered there), or null to return the status.
  v1::MapService::Stub* Follow(const grpc::Status& status, int* hops);
  // A unary call on the owner of map `name`, following redirects.
  template <class Request, class Response>
  absl::StatusOr<Response> Call(grpc::Status (v1::MapService::Stub::*method)(grpc::ClientContext*,
                                                                             const Request&,
                                                                             Response*),
                                const std::string& name, const Request& request);

  const Options options_;
  const std::string target_;
  std::shared_ptr<grpc::Channel> channel_;
  std::unique_ptr<v1::MapService::Stub> stub_;
  std::mutex mu_;                                                       // guards the two maps below
  std::map<std::string, std::unique_ptr<v1::MapService::Stub>> stubs_;  // by address
  std::map<std::string, v1::MapService::Stub*> owners_;                 // by map name
};

// The fleet redirect an error carries (from a unary call's status details), if any.
std::optional<v1::MapRedirect> RedirectOf(const absl::Status& status);

// grpc::Status -> absl::Status (same codes; a fleet redirect in the details is kept as the
// status's payload, see RedirectOf).
absl::Status FromGrpcStatus(const grpc::Status& status);

}  // namespace skimap::client

#endif  // CLIENT_MAP_CLIENT_H_
