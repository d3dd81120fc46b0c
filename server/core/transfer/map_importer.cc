#include "server/core/transfer/map_importer.h"

#include <cstdio>
#include <utility>

#include "absl/strings/str_cat.h"
#include "server/core/logging/log.h"
#include "skimap/v1/maps.pb.h"

namespace skimap::server {
namespace {

// Chunks or journal records gathered before one store write.
constexpr size_t kBatchBytes = size_t{4} << 20;
constexpr size_t kJournalBatchRecords = 64;

}  // namespace

absl::Status MapImporter::StoreError(const absl::Status& s) const {
  return absl::Status(s.code(), absl::StrCat("import of ", MapName(id_), ": ", s.message()));
}

absl::Status MapImporter::Add(std::string_view bytes) {
  if (!error_.ok()) return error_;
  if (done_) return absl::FailedPreconditionError("import: already finished");
  reader_.Feed(bytes);
  for (;;) {
    absl::StatusOr<std::optional<ExportRecord>> record = reader_.Next();
    if (!record.ok()) return Fail(record.status());
    if (!record->has_value()) return absl::OkStatus();
    if (absl::Status s = Apply(**std::move(record)); !s.ok()) return Fail(s);
  }
}

absl::Status MapImporter::Apply(ExportRecord record) {
  if (auto* map = std::get_if<ExportedMap>(&record)) return Begin(*map);
  if (auto* chunk = std::get_if<storage::Chunk>(&record)) {
    pending_bytes_ += chunk->bytes.size();
    chunks_.push_back(std::move(*chunk));
    return pending_bytes_ >= kBatchBytes ? FlushChunks() : absl::OkStatus();
  }
  if (auto* r = std::get_if<storage::JournalRecord>(&record)) {
    if (absl::Status s = FlushChunks(); !s.ok()) return s;
    pending_bytes_ += r->payload.size();
    journal_.push_back(std::move(*r));
    return pending_bytes_ >= kBatchBytes || journal_.size() >= kJournalBatchRecords
               ? FlushJournal()
               : absl::OkStatus();
  }
  // The end record: everything is in the store; the snapshot now covers its position.
  if (absl::Status s = FlushChunks(); !s.ok()) return s;
  if (absl::Status s = FlushJournal(); !s.ok()) return s;
  absl::Status s = store_->WriteSnapshot(id_, snapshot_position_, {}, {});
  return s.ok() ? s : StoreError(s);
}

absl::Status MapImporter::Begin(const ExportedMap& map) {
  id_ = requested_id_.empty() ? map.map_id : requested_id_;
  if (requested_id_.empty()) {
    if (absl::Status s = ValidateMapId(id_, "export file: map id"); !s.ok()) return s;
  }
  v1::MapOptions options;
  if (!options.ParseFromString(map.options)) {
    return absl::DataLossError("export file: map record: the map options do not parse");
  }
  absl::StatusOr<MapConfig> config = ResolveStoredMapOptions(options);
  if (!config.ok()) {
    return absl::InvalidArgumentError(absl::StrCat("export file: ", config.status().message()));
  }
  config_ = *config;
  if (absl::Status s = registry_->Reserve(id_); !s.ok()) return s;
  reserved_ = true;
  absl::Status s = store_->BeginImport(id_, ToProto(config_).SerializeAsString(), map.journal_base);
  if (!s.ok()) return StoreError(s);
  created_ = true;
  snapshot_position_ = map.snapshot_position;
  return absl::OkStatus();
}

absl::Status MapImporter::FlushChunks() {
  if (chunks_.empty()) return absl::OkStatus();
  // Covering position 0 until the end record: the map is not served before Finish anyway.
  absl::Status s = store_->WriteSnapshot(id_, 0, chunks_, {});
  if (!s.ok()) return StoreError(s);
  chunks_.clear();
  pending_bytes_ = 0;
  return absl::OkStatus();
}

absl::Status MapImporter::FlushJournal() {
  if (journal_.empty()) return absl::OkStatus();
  absl::StatusOr<uint64_t> last = store_->AppendJournal(id_, journal_);
  if (!last.ok()) return StoreError(last.status());
  if (*last != journal_.back().position) {  // BeginImport's base makes them line up
    return absl::InternalError(absl::StrCat("import of ", MapName(id_), ": journal record ",
                                            journal_.back().position, " landed at position ",
                                            *last));
  }
  journal_.clear();
  pending_bytes_ = 0;
  return absl::OkStatus();
}

absl::StatusOr<std::shared_ptr<LiveMap>> MapImporter::Finish() {
  if (!error_.ok()) return error_;
  if (done_) return absl::FailedPreconditionError("import: already finished");
  if (absl::Status s = reader_.Finish(); !s.ok()) return Fail(s);
  // Loaded as a restart would: every chunk decoded and checked, the journal tail replayed.
  absl::StatusOr<std::shared_ptr<LiveMap>> map = registry_->LoadReserved(id_, config_);
  if (!map.ok()) return Fail(map.status());
  if (absl::Status s = store_->FinishImport(id_); !s.ok()) return Fail(StoreError(s));
  registry_->Publish(id_, config_, *map);
  done_ = true;
  return map;
}

absl::Status MapImporter::Fail(absl::Status s) {
  error_ = std::move(s);
  Abort();
  return error_;
}

void MapImporter::Abort() {
  if (done_) return;
  // The store first: once the id is released, a CreateMap of it must find the store free.
  if (created_) {
    if (absl::Status s = store_->DeleteMap(id_); !s.ok()) {
      LogWarning(absl::StrCat("import of ", MapName(id_), ": the partial map was not deleted (",
                              s.ToString(), "); the next start deletes it"));
    }
    created_ = false;
  }
  if (reserved_) {
    registry_->Release(id_);
    reserved_ = false;
  }
  chunks_.clear();
  journal_.clear();
}

}  // namespace skimap::server
