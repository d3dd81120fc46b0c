// The gRPC side of ExportMap and ImportMap (callback API): each reactor moves the pieces of
// an export file between the call and the core's MapExporter / MapImporter.
//
// ExportWriteReactor: one piece per write, the next one made when the previous write is
// done, so a slow client holds the export back (HTTP/2 flow control) instead of a server
// buffer growing. ImportReadReactor: one piece per read, added to the import before the next
// read; the first message may carry the new map id. An error, or a cancelled call, ends the
// import and deletes whatever it wrote before the call finishes.
//
// Every step that touches the store (the export's first snapshot, each page read, each
// import write, the final load) runs on `blocking`, a WorkQueue of the adapter's, never on
// a gRPC callback thread: a load of a big map takes seconds.
//
// Thread safety: at most one step of a call runs at a time (the next one is started by the
// completion of the previous write or read); no state is shared between calls.
#ifndef SERVER_GRPC_MAP_TRANSFER_REACTORS_H_
#define SERVER_GRPC_MAP_TRANSFER_REACTORS_H_

#include <grpcpp/grpcpp.h>

#include <functional>
#include <memory>

#include "server/core/auth/grant.h"
#include "server/core/common/work_queue.h"
#include "server/core/transfer/map_transfer.h"
#include "skimap/v1/maps.pb.h"

namespace skimap::server {

class ExportWriteReactor final : public grpc::ServerWriteReactor<v1::ExportChunk> {
 public:
  // REQUIRES: core and blocking outlive the call. Deletes itself in OnDone.
  ExportWriteReactor(const MapTransfer* core, WorkQueue* blocking,
                     const v1::ExportMapRequest& request);
  void OnWriteDone(bool ok) override;
  void OnDone() override { delete this; }

 private:
  void Start(const v1::ExportMapRequest& request);  // on blocking_
  void WriteNext();                                 // on blocking_
  void Post(std::function<void()> step);

  WorkQueue* const blocking_;
  std::unique_ptr<MapExporter> exporter_;
  v1::ExportChunk piece_;
};

class ImportReadReactor final : public grpc::ServerReadReactor<v1::ExportChunk> {
 public:
  // REQUIRES: core and blocking outlive the call. Deletes itself in OnDone. A map_id
  // outside `grant`'s scope (or none, from a scoped grant) ends the call with
  // PERMISSION_DENIED before anything is written.
  ImportReadReactor(const MapTransfer* core, WorkQueue* blocking, grpc::CallbackServerContext* ctx,
                    v1::Map* response, auth::Grant grant = auth::Grant::Everything());
  void OnReadDone(bool ok) override;
  void OnDone() override { delete this; }

 private:
  void Step(bool ok);  // on blocking_: takes the piece just read (or the end of the file)
  // Ends the call with `s`, after the import (if any) was ended.
  void End(const absl::Status& s);

  const MapTransfer* const core_;
  WorkQueue* const blocking_;
  grpc::CallbackServerContext* const ctx_;
  v1::Map* const response_;
  const auth::Grant grant_;
  std::unique_ptr<MapImporter> importer_;  // from the first message on
  v1::ExportChunk piece_;
};

}  // namespace skimap::server

#endif  // SERVER_GRPC_MAP_TRANSFER_REACTORS_H_
