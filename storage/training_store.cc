#include "storage/training_store.h"

#include <algorithm>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "storage/schema.h"

namespace skimap::storage {

absl::StatusOr<std::unique_ptr<TrainingStore>> TrainingStore::Open(const std::string& path) {
  absl::StatusOr<std::unique_ptr<Database>> db = Database::Open(path);
  if (!db.ok()) return db.status();
  if (absl::Status s = Migrate(**db, StorageMigrations()); !s.ok()) return s;
  return std::unique_ptr<TrainingStore>(new TrainingStore(*std::move(db)));
}

absl::Status TrainingStore::Put(int obj_id, const std::vector<std::string>& blobs) {
  std::lock_guard<std::mutex> lock(mu_);
  Transaction tx(*db_);
  if (!tx.status().ok()) return tx.status();
  absl::StatusOr<Statement> del = db_->Prepare("DELETE FROM training_descriptors WHERE obj_id = ?");
  if (!del.ok()) return del.status();
  if (absl::Status s = del->BindInt(1, obj_id); !s.ok()) return s;
  if (absl::Status s = del->Run(); !s.ok()) return s;
  absl::StatusOr<Statement> ins =
      db_->Prepare("INSERT INTO training_descriptors(obj_id, rank, descriptors) VALUES (?, ?, ?)");
  if (!ins.ok()) return ins.status();
  for (size_t rank = 0; rank < blobs.size(); ++rank) {
    ins->Reset();
    absl::Status s = ins->BindInt(1, obj_id);
    if (s.ok()) s = ins->BindInt(2, static_cast<int64_t>(rank));
    if (s.ok()) s = ins->BindBlob(3, blobs[rank]);
    if (s.ok()) s = ins->Run();
    if (!s.ok()) return s;
  }
  return tx.Commit();
}

absl::StatusOr<std::vector<std::string>> TrainingStore::Get(int obj_id) {
  std::lock_guard<std::mutex> lock(mu_);
  absl::StatusOr<Statement> st = db_->Prepare(
      "SELECT rank, descriptors FROM training_descriptors WHERE obj_id = ? ORDER BY rank");
  if (!st.ok()) return st.status();
  if (absl::Status s = st->BindInt(1, obj_id); !s.ok()) return s;
  std::vector<std::string> out;
  for (;;) {
    absl::StatusOr<bool> row = st->Step();
    if (!row.ok()) return row.status();
    if (!*row) break;
    if (st->ColumnInt(0) != static_cast<int64_t>(out.size())) {
      return absl::DataLossError(
          absl::StrCat("training_descriptors: object ", obj_id, " has a rank gap"));
    }
    out.push_back(st->ColumnBlob(1));
  }
  if (out.empty()) {
    return absl::NotFoundError(
        absl::StrCat("training_descriptors: none stored for object ", obj_id));
  }
  return out;
}

absl::Status TrainingStore::Delete(int obj_id) {
  std::lock_guard<std::mutex> lock(mu_);
  absl::StatusOr<Statement> st = db_->Prepare("DELETE FROM training_descriptors WHERE obj_id = ?");
  if (!st.ok()) return st.status();
  if (absl::Status s = st->BindInt(1, obj_id); !s.ok()) return s;
  return st->Run();
}

absl::Status TrainingStore::DeleteAllExcept(const std::vector<int>& keep) {
  std::lock_guard<std::mutex> lock(mu_);
  // obj_ids are integers, so joining them into the statement is safe.
  return db_->Exec(absl::StrCat("DELETE FROM training_descriptors WHERE obj_id NOT IN (",
                                absl::StrJoin(keep, ","), ");"));
}

}  // namespace skimap::storage
