// TrainingStore: the raw training descriptors of each object's voxels (table
// training_descriptors, migration 2), next to the object database in the same SQLite file.
// The forest trains on raw descriptors while the object database keeps only centroids, so
// the object service persists them here to rebuild the classifier after a restart or a
// delete. Storage knows blobs only: each voxel's descriptors are one opaque blob
// (perception/objects encodes a DescriptorMatrix into it).
//
//   auto store = TrainingStore::Open(DATA_DIR + "/objects.sqlite");  // creates + migrates
//   RETURN_IF_ERROR((*store)->Put(3, blobs));    // replaces object 3's blobs, atomically
//   absl::StatusOr<std::vector<std::string>> blobs = (*store)->Get(3);  // rank order
//
// Thread safety: thread safe (calls are serialized by an internal mutex). It opens its own
// connection, so it may be used beside an ObjectStore on the same file.
#ifndef SKIMAP_STORAGE_TRAINING_STORE_H_
#define SKIMAP_STORAGE_TRAINING_STORE_H_

#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "storage/sqlite.h"

namespace skimap::storage {

class TrainingStore {
 public:
  // Opens or creates the SQLite file and migrates it to the current schema.
  static absl::StatusOr<std::unique_ptr<TrainingStore>> Open(const std::string& path);

  // Replaces the blobs of obj_id with `blobs` (index = voxel rank), in one transaction.
  absl::Status Put(int obj_id, const std::vector<std::string>& blobs);
  // The blobs of obj_id in rank order; NotFound if none are stored (or a rank is missing:
  // DataLoss).
  absl::StatusOr<std::vector<std::string>> Get(int obj_id);
  // Deletes the blobs of obj_id (OK if there were none).
  absl::Status Delete(int obj_id);
  // Deletes the blobs of every object not in `keep` (orphans of an interrupted write).
  absl::Status DeleteAllExcept(const std::vector<int>& keep);

 private:
  explicit TrainingStore(std::unique_ptr<Database> db) : db_(std::move(db)) {}

  std::mutex mu_;
  std::unique_ptr<Database> db_;  // guarded by mu_
};

}  // namespace skimap::storage

#endif  // SKIMAP_STORAGE_TRAINING_STORE_H_
