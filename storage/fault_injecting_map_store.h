// FaultInjectingMapStore: a MapStore that forwards to another one but fails chosen writes,
// for tests of what the server does when the disk fails (issue 10: "writes failing at the
// N-th call, for many N").
//
//   FaultInjectingMapStore store(std::move(real));
//   store.FailWriteNumber(3, absl::ResourceExhaustedError("disk full"));  // the 3rd write
//
// A failed write reaches nothing below (so it changes nothing, as the contract requires);
// reads always pass through. Writes are CreateMap, DeleteMap, BeginImport, FinishImport,
// AppendJournal, PruneJournal and WriteSnapshot, counted from 1 across all of them.
// HoldAppends makes AppendJournal calls wait until ReleaseAppends (a map's worker is then
// held inside an append while the test queues frames behind it); appends() and
// appended_records() count what reached the store below.
//
// Thread safety: thread safe.
#ifndef SKIMAP_STORAGE_FAULT_INJECTING_MAP_STORE_H_
#define SKIMAP_STORAGE_FAULT_INJECTING_MAP_STORE_H_

#include <condition_variable>
#include <memory>
#include <mutex>

#include "storage/map_store.h"

namespace skimap::storage {

class FaultInjectingMapStore final : public MapStore {
 public:
  explicit FaultInjectingMapStore(std::unique_ptr<MapStore> base) : base_(std::move(base)) {}

  // Makes the n-th write from now (n >= 1) fail with `error`; every write after it
  // succeeds again. n = 0 disarms.
  void FailWriteNumber(int n, absl::Status error) {
    std::lock_guard<std::mutex> lock(mu_);
    countdown_ = n;
    error_ = std::move(error);
  }
  // Writes attempted so far (failed ones included).
  int writes() {
    std::lock_guard<std::mutex> lock(mu_);
    return writes_;
  }

  absl::Status CreateMap(const std::string& id, const std::string& options) override {
    if (absl::Status s = Write(); !s.ok()) return s;
    return base_->CreateMap(id, options);
  }
  absl::Status DeleteMap(const std::string& id) override {
    if (absl::Status s = Write(); !s.ok()) return s;
    return base_->DeleteMap(id);
  }
  absl::Status BeginImport(const std::string& id, const std::string& options,
                           uint64_t journal_base) override {
    if (absl::Status s = Write(); !s.ok()) return s;
    return base_->BeginImport(id, options, journal_base);
  }
  absl::Status FinishImport(const std::string& id) override {
    if (absl::Status s = Write(); !s.ok()) return s;
    return base_->FinishImport(id);
  }
  void HoldAppends() {
    std::lock_guard<std::mutex> lock(mu_);
    hold_ = true;
  }
  void ReleaseAppends() {
    {
      std::lock_guard<std::mutex> lock(mu_);
      hold_ = false;
    }
    released_.notify_all();
  }
  // AppendJournal calls waiting in a hold now.
  int appends_waiting() {
    std::lock_guard<std::mutex> lock(mu_);
    return waiting_;
  }
  // AppendJournal calls that succeeded below, and the records they carried.
  int appends() {
    std::lock_guard<std::mutex> lock(mu_);
    return appends_;
  }
  int appended_records() {
    std::lock_guard<std::mutex> lock(mu_);
    return appended_records_;
  }

  absl::StatusOr<std::vector<StoredMap>> ListMaps() override { return base_->ListMaps(); }
  absl::StatusOr<StoredMap> GetMap(const std::string& id) override { return base_->GetMap(id); }
  absl::StatusOr<uint64_t> AppendJournal(const std::string& id,
                                         const std::vector<JournalRecord>& records) override {
    {
      std::unique_lock<std::mutex> lock(mu_);
      ++waiting_;
      released_.wait(lock, [&] { return !hold_; });
      --waiting_;
    }
    if (absl::Status s = Write(); !s.ok()) return s;
    absl::StatusOr<uint64_t> last = base_->AppendJournal(id, records);
    if (last.ok()) {
      std::lock_guard<std::mutex> lock(mu_);
      ++appends_;
      appended_records_ += static_cast<int>(records.size());
    }
    return last;
  }
  absl::Status ReadJournal(const std::string& id, uint64_t after, size_t limit,
                           const std::function<absl::Status(const JournalRecord&)>& fn) override {
    return base_->ReadJournal(id, after, limit, fn);
  }
  absl::StatusOr<JournalRecord> ReadJournalRecord(const std::string& id,
                                                  uint64_t position) override {
    return base_->ReadJournalRecord(id, position);
  }
  absl::Status PruneJournal(const std::string& id, uint64_t upto) override {
    if (absl::Status s = Write(); !s.ok()) return s;
    return base_->PruneJournal(id, upto);
  }
  absl::Status WriteSnapshot(const std::string& id, uint64_t covers_position,
                             const std::vector<Chunk>& changed,
                             const std::vector<ChunkKey>& removed) override {
    if (absl::Status s = Write(); !s.ok()) return s;
    return base_->WriteSnapshot(id, covers_position, changed, removed);
  }
  absl::StatusOr<uint64_t> ReadSnapshot(
      const std::string& id, const std::function<absl::Status(const Chunk&)>& fn) override {
    return base_->ReadSnapshot(id, fn);
  }
  absl::StatusOr<uint64_t> ReadSnapshotPage(
      const std::string& id, const std::optional<ChunkKey>& after, size_t limit,
      const std::function<absl::Status(const Chunk&)>& fn) override {
    return base_->ReadSnapshotPage(id, after, limit, fn);
  }

 private:
  absl::Status Write() {
    std::lock_guard<std::mutex> lock(mu_);
    ++writes_;
    if (countdown_ > 0 && --countdown_ == 0) return error_;
    return absl::OkStatus();
  }

  std::mutex mu_;
  std::unique_ptr<MapStore> base_;
  std::condition_variable released_;
  int countdown_ = 0;
  int writes_ = 0;
  bool hold_ = false;
  int waiting_ = 0;
  int appends_ = 0;
  int appended_records_ = 0;
  absl::Status error_;
};

}  // namespace skimap::storage

#endif  // SKIMAP_STORAGE_FAULT_INJECTING_MAP_STORE_H_
