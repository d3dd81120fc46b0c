#include "server/core/transfer/map_exporter.h"

#include <algorithm>
#include <utility>

#include "absl/strings/str_cat.h"

namespace skimap::server {
namespace {

constexpr size_t kChunkPage = 64;    // chunks per store read (blobs of a few KiB each)
constexpr size_t kJournalBatch = 8;  // journal records per store read (frames: ~1 MiB each)

absl::Status Changed(const std::string& id, const std::string& what) {
  return absl::AbortedError(
      absl::StrCat("export of ", MapName(id), ": ", what, " changed during the export; retry"));
}

}  // namespace

absl::StatusOr<std::unique_ptr<MapExporter>> MapExporter::Start(std::shared_ptr<LiveMap> map,
                                                                storage::MapStore* store,
                                                                const Options& options) {
  absl::StatusOr<LiveMap::SnapshotHold> hold = map->SnapshotAndHold();
  if (!hold.ok()) return hold.status();
  const std::string& id = map->id();
  absl::StatusOr<storage::StoredMap> stored = store->GetMap(id);
  if (!stored.ok()) return stored.status();
  std::unique_ptr<MapExporter> e(new MapExporter(std::move(map), *std::move(hold), store, options));
  e->snapshot_position_ = stored->snapshot_position;
  // Without the journal the file's positions end where the snapshot does: an import
  // continues the journal after it (the frames before it are then pruned).
  uint64_t base = stored->snapshot_position;
  e->journal_end_ = stored->snapshot_position;
  if (options.with_journal) {
    uint64_t first = 0;
    absl::Status read = store->ReadJournal(id, 0, 1, [&](const storage::JournalRecord& r) {
      first = r.position;
      return absl::OkStatus();
    });
    if (!read.ok()) return read;
    base = first > 0 ? first - 1 : stored->last_position;
    e->journal_end_ = stored->last_position;
    if (base > stored->snapshot_position) {  // pruning never passes the snapshot
      return absl::DataLossError(absl::StrCat("journal of ", MapName(id), ": records ",
                                              stored->snapshot_position + 1, "..", base,
                                              " after its snapshot are missing"));
    }
  }
  e->journal_next_ = base + 1;
  e->writer_.emplace(ExportedMap{.map_id = id,
                                 .options = stored->options,
                                 .snapshot_position = stored->snapshot_position,
                                 .journal_base = base},
                     &e->pending_);
  return e;
}

absl::StatusOr<std::optional<std::string>> MapExporter::Next() {
  while (pending_.size() - offset_ < options_.piece_bytes && stage_ != Stage::kDone) {
    if (offset_ > 0) {  // fewer than piece_bytes left: cheap to move
      pending_.erase(0, offset_);
      offset_ = 0;
    }
    if (absl::Status s = Fill(); !s.ok()) return s;
  }
  const size_t left = pending_.size() - offset_;
  if (left == 0) return std::nullopt;
  std::string piece;
  if (offset_ == 0 && left <= options_.piece_bytes) {
    piece = std::move(pending_);
    pending_.clear();
  } else {
    const size_t n = std::min(left, options_.piece_bytes);
    piece = pending_.substr(offset_, n);
    offset_ += n;
    if (offset_ == pending_.size()) {
      pending_.clear();
      offset_ = 0;
    }
  }
  return piece;
}

absl::Status MapExporter::Fill() {
  switch (stage_) {
    case Stage::kChunks:
      return FillChunks();
    case Stage::kJournal:
      return FillJournal();
    case Stage::kEnd:
      writer_->Finish(&pending_);
      stage_ = Stage::kDone;
      return absl::OkStatus();
    case Stage::kDone:
      return absl::OkStatus();
  }
  return absl::OkStatus();
}

absl::Status MapExporter::FillChunks() {
  size_t n = 0;
  absl::StatusOr<uint64_t> covered =
      store_->ReadSnapshotPage(map_->id(), after_, kChunkPage, [&](const storage::Chunk& c) {
        writer_->AddChunk(c, &pending_);
        after_ = c.key;
        ++n;
        return absl::OkStatus();
      });
  if (!covered.ok()) return covered.status();
  if (*covered != snapshot_position_) return Changed(map_->id(), "its snapshot");
  if (n < kChunkPage) {
    stage_ = journal_next_ <= journal_end_ && options_.with_journal ? Stage::kJournal : Stage::kEnd;
  }
  return absl::OkStatus();
}

absl::Status MapExporter::FillJournal() {
  const size_t limit = std::min<uint64_t>(kJournalBatch, journal_end_ - journal_next_ + 1);
  const uint64_t expected = journal_next_;
  absl::Status read = store_->ReadJournal(map_->id(), journal_next_ - 1, limit,
                                          [&](const storage::JournalRecord& r) {
                                            if (r.position != journal_next_)
                                              return Changed(map_->id(), "its journal");
                                            writer_->AddJournal(r, &pending_);
                                            ++journal_next_;
                                            return absl::OkStatus();
                                          });
  if (!read.ok()) return read;
  if (journal_next_ == expected) return Changed(map_->id(), "its journal");  // records vanished
  if (journal_next_ > journal_end_) stage_ = Stage::kEnd;
  return absl::OkStatus();
}

}  // namespace skimap::server
