#include "server/grpc/map_transfer_reactors.h"

#include <utility>

#include "server/core/auth/access.h"
#include "server/grpc/grpc_status.h"

namespace skimap::server {

namespace {

grpc::Status ShuttingDown() {
  return grpc::Status(grpc::StatusCode::UNAVAILABLE, "the server is shutting down");
}

}  // namespace

ExportWriteReactor::ExportWriteReactor(const MapTransfer* core, WorkQueue* blocking,
                                       const v1::ExportMapRequest& request)
    : blocking_(blocking) {
  Post([this, core, request] {
    absl::StatusOr<std::unique_ptr<MapExporter>> exporter = core->Export(request);
    if (!exporter.ok()) return Finish(ToGrpcStatus(exporter.status()));
    exporter_ = *std::move(exporter);
    WriteNext();
  });
}

void ExportWriteReactor::Post(std::function<void()> step) {
  if (!blocking_->Submit(std::move(step))) Finish(ShuttingDown());
}

void ExportWriteReactor::OnWriteDone(bool ok) {
  if (!ok) return Finish(grpc::Status(grpc::StatusCode::CANCELLED, "client went away"));
  Post([this] { WriteNext(); });
}

void ExportWriteReactor::WriteNext() {
  absl::StatusOr<std::optional<std::string>> piece = exporter_->Next();
  if (!piece.ok()) return Finish(ToGrpcStatus(piece.status()));
  if (!piece->has_value()) return Finish(grpc::Status::OK);
  piece_.set_data(**std::move(piece));
  StartWrite(&piece_);
}

ImportReadReactor::ImportReadReactor(const MapTransfer* core, WorkQueue* blocking,
                                     grpc::CallbackServerContext* ctx, v1::Map* response,
                                     auth::Grant grant)
    : core_(core), blocking_(blocking), ctx_(ctx), response_(response), grant_(std::move(grant)) {
  StartRead(&piece_);
}

void ImportReadReactor::OnReadDone(bool ok) {
  if (!blocking_->Submit([this, ok] { Step(ok); })) {
    importer_.reset();
    Finish(ShuttingDown());
  }
}

void ImportReadReactor::End(const absl::Status& s) {
  importer_.reset();  // an unfinished import deletes what it wrote
  Finish(ToGrpcStatus(s));
}

void ImportReadReactor::Step(bool ok) {
  if (!ok && ctx_->IsCancelled()) return End(absl::CancelledError("import cancelled"));
  if (importer_ == nullptr) {  // the first message (or an empty stream)
    if (grant_.Scoped()) {
      const std::string map = "maps/" + (ok ? piece_.map_id() : "");
      if (absl::Status s = grant_.CheckMap(auth::MethodRole("MapService/ImportMap"), map); !s.ok())
        return End(s);
    }
    absl::StatusOr<std::unique_ptr<MapImporter>> importer =
        core_->Import(ok ? piece_.map_id() : "");
    if (!importer.ok()) return End(importer.status());
    importer_ = *std::move(importer);
  }
  if (!ok) {  // the client sent the whole file
    absl::StatusOr<v1::Map> map = core_->Finish(*importer_);
    if (map.ok()) *response_ = *std::move(map);
    return End(map.status());
  }
  if (absl::Status s = importer_->Add(piece_.data()); !s.ok()) return End(s);
  StartRead(&piece_);
}

}  // namespace skimap::server
