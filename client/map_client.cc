#include "client/map_client.h"

#include <chrono>

namespace skimap::client {

absl::Status FromGrpcStatus(const grpc::Status& s) {
  if (s.ok()) return absl::OkStatus();
  return absl::Status(static_cast<absl::StatusCode>(s.error_code()), s.error_message());
}

std::shared_ptr<grpc::Channel> MakeChannel(const std::string& target, int max_message_bytes) {
  grpc::ChannelArguments args;
  args.SetMaxReceiveMessageSize(max_message_bytes);
  args.SetMaxSendMessageSize(max_message_bytes);
  return grpc::CreateCustomChannel(target, grpc::InsecureChannelCredentials(), args);
}

std::unique_ptr<MapClient> MapClient::Connect(const std::string& target, const Options& options) {
  return std::unique_ptr<MapClient>(
      new MapClient(MakeChannel(target, options.max_message_bytes), options));
}

MapClient::MapClient(std::shared_ptr<grpc::Channel> channel, const Options& options)
    : options_(options), channel_(std::move(channel)), stub_(v1::MapService::NewStub(channel_)) {}

absl::Status MapClient::WaitForServer(absl::Duration timeout) {
  if (channel_->WaitForConnected(absl::ToChronoTime(absl::Now() + timeout))) {
    return absl::OkStatus();
  }
  return absl::UnavailableError("server did not answer in time");
}

void MapClient::SetDeadline(grpc::ClientContext* ctx) const {
  ctx->set_deadline(absl::ToChronoTime(absl::Now() + options_.timeout));
}

namespace {

// A unary call with a fresh context and deadline; the status converted once.
template <class Request, class Response>
absl::StatusOr<Response> Unary(v1::MapService::Stub& stub,
                               grpc::Status (v1::MapService::Stub::*method)(grpc::ClientContext*,
                                                                            const Request&,
                                                                            Response*),
                               const Request& request, absl::Duration timeout) {
  grpc::ClientContext ctx;
  ctx.set_deadline(absl::ToChronoTime(absl::Now() + timeout));
  Response response;
  const grpc::Status s = (stub.*method)(&ctx, request, &response);
  if (!s.ok()) return FromGrpcStatus(s);
  return response;
}

}  // namespace

absl::StatusOr<v1::Map> MapClient::CreateMap(const v1::CreateMapRequest& request) {
  return Unary(*stub_, &v1::MapService::Stub::CreateMap, request, options_.timeout);
}

absl::StatusOr<v1::Map> MapClient::GetMap(const std::string& name) {
  v1::GetMapRequest request;
  request.set_name(name);
  return Unary(*stub_, &v1::MapService::Stub::GetMap, request, options_.timeout);
}

absl::StatusOr<v1::ListMapsResponse> MapClient::ListMaps(const v1::ListMapsRequest& request) {
  return Unary(*stub_, &v1::MapService::Stub::ListMaps, request, options_.timeout);
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
  grpc::ClientContext ctx;
  SetDeadline(&ctx);
  v1::DeleteMapResponse response;
  return FromGrpcStatus(stub_->DeleteMap(&ctx, request, &response));
}

absl::StatusOr<v1::FrameAck> MapClient::IntegrateFrame(const v1::Frame& frame) {
  return Unary(*stub_, &v1::MapService::Stub::IntegrateFrame, frame, options_.timeout);
}

absl::StatusOr<v1::UpdatePosesResponse> MapClient::UpdatePoses(
    const v1::UpdatePosesRequest& request) {
  return Unary(*stub_, &v1::MapService::Stub::UpdatePoses, request, options_.timeout);
}

std::unique_ptr<FrameStream> MapClient::OpenFrameStream(const FrameStream::Options& options) {
  return std::make_unique<FrameStream>(stub_.get(), options);
}

absl::StatusOr<v1::OccupancyGrid> MapClient::GetOccupancyGrid(
    const v1::GetOccupancyGridRequest& request) {
  return Unary(*stub_, &v1::MapService::Stub::GetOccupancyGrid, request, options_.timeout);
}

absl::StatusOr<v1::HeightMap> MapClient::GetHeightMap(const v1::GetHeightMapRequest& request) {
  return Unary(*stub_, &v1::MapService::Stub::GetHeightMap, request, options_.timeout);
}

absl::StatusOr<v1::GetVoxelsResponse> MapClient::GetVoxels(const v1::GetVoxelsRequest& request) {
  return Unary(*stub_, &v1::MapService::Stub::GetVoxels, request, options_.timeout);
}

absl::StatusOr<std::vector<v1::Voxel>> MapClient::GetAllVoxels(
    const v1::GetVoxelsRequest& request) {
  grpc::ClientContext ctx;
  SetDeadline(&ctx);
  std::unique_ptr<grpc::ClientReader<v1::GetVoxelsResponse>> reader =
      stub_->StreamVoxels(&ctx, request);
  std::vector<v1::Voxel> voxels;
  v1::GetVoxelsResponse page;
  while (reader->Read(&page))
    voxels.insert(voxels.end(), page.voxels().begin(), page.voxels().end());
  grpc::Status s = reader->Finish();
  if (!s.ok()) return FromGrpcStatus(s);
  return voxels;
}

absl::StatusOr<v1::RadiusSearchResponse> MapClient::RadiusSearch(
    const v1::RadiusSearchRequest& request) {
  return Unary(*stub_, &v1::MapService::Stub::RadiusSearch, request, options_.timeout);
}

absl::Status MapClient::ExportMap(const v1::ExportMapRequest& request,
                                  const std::function<absl::Status(std::string_view)>& sink) {
  grpc::ClientContext ctx;
  ctx.set_deadline(absl::ToChronoTime(absl::Now() + options_.transfer_timeout));
  std::unique_ptr<grpc::ClientReader<v1::ExportChunk>> reader = stub_->ExportMap(&ctx, request);
  v1::ExportChunk piece;
  absl::Status sunk;
  while (reader->Read(&piece)) {
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
  return FromGrpcStatus(s);
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
