#include "client/map_client.h"

#include <chrono>

#include "absl/strings/cord.h"
#include "absl/strings/str_cat.h"
#include "codec/zstd_frame.h"
#include "grpc/health/v1/health.grpc.pb.h"

namespace skimap::client {

namespace {

constexpr char kRedirectUrl[] = "type.googleapis.com/skimap.v1.MapRedirect";

// The MapRedirect in a call's status details (skimap.v1.StatusDetails), if any.
std::optional<v1::MapRedirect> DetailsRedirect(const grpc::Status& s) {
  if (s.error_details().empty()) return std::nullopt;
  v1::StatusDetails details;
  if (!details.ParseFromString(s.error_details())) return std::nullopt;
  for (const google::protobuf::Any& any : details.details()) {
    v1::MapRedirect r;
    if (any.UnpackTo(&r) && !r.address().empty()) return r;
  }
  return std::nullopt;
}

}  // namespace

absl::Status FromGrpcStatus(const grpc::Status& s) {
  if (s.ok()) return absl::OkStatus();
  absl::Status out(static_cast<absl::StatusCode>(s.error_code()), s.error_message());
  if (std::optional<v1::MapRedirect> r = DetailsRedirect(s)) {
    out.SetPayload(kRedirectUrl, absl::Cord(r->SerializeAsString()));
  }
  return out;
}

std::optional<v1::MapRedirect> RedirectOf(const absl::Status& status) {
  absl::optional<absl::Cord> payload = status.GetPayload(kRedirectUrl);
  v1::MapRedirect r;
  if (!payload.has_value() || !r.ParseFromString(std::string(*payload))) return std::nullopt;
  return r;
}

std::unique_ptr<MapClient> MapClient::Connect(const std::string& target, const Options& options) {
  return std::unique_ptr<MapClient>(new MapClient(target, options));
}

MapClient::MapClient(const std::string& target, const Options& options)
    : options_(options),
      target_(target),
      channel_(MakeChannel(target, options.max_message_bytes, options.connection)),
      stub_(v1::MapService::NewStub(channel_)) {}

v1::MapService::Stub* MapClient::StubForMap(const std::string& name) {
  std::lock_guard<std::mutex> lock(mu_);
  auto it = owners_.find(name);
  return it == owners_.end() ? stub_.get() : it->second;
}

v1::MapService::Stub* MapClient::Follow(const grpc::Status& status, int* hops) {
  std::optional<v1::MapRedirect> r = DetailsRedirect(status);
  if (!r.has_value() || *hops >= options_.max_redirects) return nullptr;
  ++*hops;
  std::lock_guard<std::mutex> lock(mu_);
  std::unique_ptr<v1::MapService::Stub>& stub = stubs_[r->address()];
  if (stub == nullptr) {
    stub = v1::MapService::NewStub(
        MakeChannel(r->address(), options_.max_message_bytes, options_.connection));
  }
  owners_[r->map()] = stub.get();
  return stub.get();
}

template <class Request, class Response>
absl::StatusOr<Response> MapClient::Call(
    grpc::Status (v1::MapService::Stub::*method)(grpc::ClientContext*, const Request&, Response*),
    const std::string& name, const Request& request) {
  v1::MapService::Stub* stub = StubForMap(name);
  for (int hops = 0;;) {
    grpc::ClientContext ctx;
    SetDeadline(&ctx);
    Response response;
    const grpc::Status s = (stub->*method)(&ctx, request, &response);
    if (s.ok()) return response;
    stub = Follow(s, &hops);
    if (stub == nullptr) return FromGrpcStatus(s);
  }
}

absl::StatusOr<v1::ListNodesResponse> MapClient::ListNodes() {
  std::unique_ptr<v1::FleetService::Stub> fleet = v1::FleetService::NewStub(channel_);
  grpc::ClientContext ctx;
  SetDeadline(&ctx);
  v1::ListNodesResponse response;
  const grpc::Status s = fleet->ListNodes(&ctx, v1::ListNodesRequest(), &response);
  if (s.error_code() == grpc::StatusCode::UNIMPLEMENTED) {
    return absl::FailedPreconditionError(
        absl::StrCat(target_, " is not a fleet node (skimapd without --store=postgresql://...)"));
  }
  if (!s.ok()) return FromGrpcStatus(s);
  return response;
}

absl::Status MapClient::WaitForServer(absl::Duration timeout) {
  if (channel_->WaitForConnected(absl::ToChronoTime(absl::Now() + timeout))) {
    return absl::OkStatus();
  }
  return absl::UnavailableError("server did not answer in time");
}

absl::Status MapClient::CheckHealth() {
  std::unique_ptr<grpc::health::v1::Health::Stub> health =
      grpc::health::v1::Health::NewStub(channel_);
  grpc::ClientContext ctx;
  SetDeadline(&ctx);
  grpc::health::v1::HealthCheckResponse response;
  const grpc::Status s = health->Check(&ctx, grpc::health::v1::HealthCheckRequest(), &response);
  if (!s.ok()) return FromGrpcStatus(s);
  if (response.status() != grpc::health::v1::HealthCheckResponse::SERVING) {
    return absl::UnavailableError(
        absl::StrCat("server is ",
                     grpc::health::v1::HealthCheckResponse::ServingStatus_Name(response.status())));
  }
  return absl::OkStatus();
}

void MapClient::SetDeadline(grpc::ClientContext* ctx) const {
  ctx->set_deadline(absl::ToChronoTime(absl::Now() + options_.timeout));
}

absl::StatusOr<v1::Map> MapClient::CreateMap(const v1::CreateMapRequest& request) {
  return Call(&v1::MapService::Stub::CreateMap, "maps/" + request.map_id(), request);
}

absl::StatusOr<v1::Map> MapClient::GetMap(const std::string& name) {
  v1::GetMapRequest request;
  request.set_name(name);
  return Call(&v1::MapService::Stub::GetMap, name, request);
}

absl::StatusOr<v1::ListMapsResponse> MapClient::ListMaps(const v1::ListMapsRequest& request) {
  return Call(&v1::MapService::Stub::ListMaps, "", request);  // any node lists every map
}

absl::StatusOr<std::vector<v1::Map>> MapClient::ListAllMaps() {
  std::vector<v1::Map> maps;
  v1::ListMapsRequest request;
  do {
    absl::StatusOr<v1::ListMapsResponse> page = ListMaps(request);
    if (!page.ok()) return page.status();
    maps.insert(maps.end(), page->maps().begin(), page->maps().end());
    request.set_page_token(page->next_page_token());
  } while (!request.page_token().empty());
  return maps;
}

absl::Status MapClient::DeleteMap(const std::string& name) {
  v1::DeleteMapRequest request;
  request.set_name(name);
  return Call(&v1::MapService::Stub::DeleteMap, name, request).status();
}

absl::StatusOr<v1::FrameAck> MapClient::IntegrateFrame(const v1::Frame& frame) {
  return Call(&v1::MapService::Stub::IntegrateFrame, frame.map(), frame);
}

absl::StatusOr<v1::UpdatePosesResponse> MapClient::UpdatePoses(
    const v1::UpdatePosesRequest& request) {
  return Call(&v1::MapService::Stub::UpdatePoses, request.map(), request);
}

std::unique_ptr<FrameStream> MapClient::OpenFrameStream(const FrameStream::Options& options,
                                                        const std::string& map) {
  return std::make_unique<FrameStream>(StubForMap(map), options);
}

absl::StatusOr<v1::OccupancyGrid> MapClient::GetOccupancyGrid(
    const v1::GetOccupancyGridRequest& request) {
  absl::StatusOr<v1::OccupancyGrid> grid =
      Call(&v1::MapService::Stub::GetOccupancyGrid, request.map(), request);
  if (!grid.ok() || grid->data_encoding() == v1::GRID_ENCODING_RAW) return grid;
  if (grid->data_encoding() != v1::GRID_ENCODING_ZSTD) {
    return absl::DataLossError(
        absl::StrCat("occupancy grid: unknown data_encoding ", grid->data_encoding()));
  }
  const size_t cells = size_t(grid->width()) * grid->height();
  // A grid is at most one message of raw cells (the server's reply limit); a larger claim
  // is refused before anything is allocated.
  if (cells > size_t(options_.max_message_bytes)) {
    return absl::DataLossError("occupancy grid: width*height exceeds the message limit");
  }
  const std::string& packed = grid->data();
  if (!perception::ZstdCheckFrame(packed, cells).ok()) {
    return absl::DataLossError("occupancy grid: the zstd data does not hold width*height cells");
  }
  std::string raw(cells, '\0');
  if (!perception::ZstdDecompressExact(packed, raw.data(), cells).ok()) {
    return absl::DataLossError("occupancy grid: the zstd data does not decode");
  }
  grid->set_data(std::move(raw));
  grid->set_data_encoding(v1::GRID_ENCODING_RAW);
  return grid;
}

absl::StatusOr<v1::HeightMap> MapClient::GetHeightMap(const v1::GetHeightMapRequest& request) {
  return Call(&v1::MapService::Stub::GetHeightMap, request.map(), request);
}

absl::StatusOr<v1::GetVoxelsResponse> MapClient::GetVoxels(const v1::GetVoxelsRequest& request) {
  return Call(&v1::MapService::Stub::GetVoxels, request.map(), request);
}

absl::StatusOr<std::vector<v1::Voxel>> MapClient::GetAllVoxels(
    const v1::GetVoxelsRequest& request) {
  v1::MapService::Stub* stub = StubForMap(request.map());
  for (int hops = 0;;) {
    grpc::ClientContext ctx;
    SetDeadline(&ctx);
    std::unique_ptr<grpc::ClientReader<v1::GetVoxelsResponse>> reader =
        stub->StreamVoxels(&ctx, request);
    std::vector<v1::Voxel> voxels;
    v1::GetVoxelsResponse page;
    while (reader->Read(&page)) {
      voxels.insert(voxels.end(), page.voxels().begin(), page.voxels().end());
    }
    const grpc::Status s = reader->Finish();
    if (s.ok()) return voxels;
    // A redirect comes before the first page.
    if (!voxels.empty() || (stub = Follow(s, &hops)) == nullptr) return FromGrpcStatus(s);
  }
}

absl::StatusOr<v1::RadiusSearchResponse> MapClient::RadiusSearch(
    const v1::RadiusSearchRequest& request) {
  return Call(&v1::MapService::Stub::RadiusSearch, request.map(), request);
}

absl::StatusOr<std::vector<v1::Instance>> MapClient::ListAllInstances(
    v1::ListInstancesRequest request) {
  std::vector<v1::Instance> out;
  for (;;) {
    absl::StatusOr<v1::ListInstancesResponse> page =
        Call(&v1::MapService::Stub::ListInstances, request.map(), request);
    if (!page.ok()) return page.status();
    out.insert(out.end(), page->instances().begin(), page->instances().end());
    if (page->next_page_token().empty()) return out;
    request.set_page_token(page->next_page_token());
  }
}

absl::Status MapClient::ExportMap(const v1::ExportMapRequest& request,
                                  const std::function<absl::Status(std::string_view)>& sink) {
  v1::MapService::Stub* stub = StubForMap(request.name());
  for (int hops = 0;;) {
    grpc::ClientContext ctx;
    ctx.set_deadline(absl::ToChronoTime(absl::Now() + options_.transfer_timeout));
    std::unique_ptr<grpc::ClientReader<v1::ExportChunk>> reader = stub->ExportMap(&ctx, request);
    v1::ExportChunk piece;
    absl::Status sunk;
    bool any = false;
    while (reader->Read(&piece)) {
      any = true;
      sunk = sink(piece.data());
      if (!sunk.ok()) {
        ctx.TryCancel();
        while (reader->Read(&piece)) {
        }
        break;
      }
    }
    const grpc::Status s = reader->Finish();
    if (!sunk.ok()) return sunk;
    // A redirect comes before the first piece.
    if (s.ok() || any || (stub = Follow(s, &hops)) == nullptr) return FromGrpcStatus(s);
  }
}

absl::StatusOr<v1::Map> MapClient::ImportMap(
    const std::string& map_id, const std::function<absl::StatusOr<std::string>()>& source) {
  grpc::ClientContext ctx;
  ctx.set_deadline(absl::ToChronoTime(absl::Now() + options_.transfer_timeout));
  v1::Map response;
  std::unique_ptr<grpc::ClientWriter<v1::ExportChunk>> writer = stub_->ImportMap(&ctx, &response);
  v1::ExportChunk piece;
  piece.set_map_id(map_id);
  absl::Status read;
  for (;;) {
    absl::StatusOr<std::string> data = source();
    if (!data.ok()) {
      read = data.status();
      ctx.TryCancel();
      break;
    }
    if (data->empty()) break;
    piece.set_data(*std::move(data));
    if (!writer->Write(piece)) break;  // the server ended the call; Finish says why
    piece.clear_map_id();
  }
  writer->WritesDone();
  const grpc::Status s = writer->Finish();
  if (!read.ok()) return read;
  if (!s.ok()) return FromGrpcStatus(s);
  return response;
}

}  // namespace skimap::client
