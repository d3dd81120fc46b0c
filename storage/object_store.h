// ObjectStore: the object database in SQLite (tables in schema.cc, described in
// docs/objects.md). Storage knows records and blobs only — no OpenCV, no forest code:
// server/core/objects/object_database_io.h converts an ObjectDatabase to and from these records.
//
//   auto store = ObjectStore::Open("/var/lib/skimap/skimap.db");   // creates + migrates
//   RETURN_IF_ERROR((*store)->Save(records));    // replaces the whole object database
//   absl::StatusOr<StoredObjectDatabase> r = (*store)->Load();
//
// Save is atomic (one transaction): a reader sees the old or the new database, never a mix.
// Thread safety: thread safe (calls are serialized by an internal mutex).
#ifndef SKIMAP_STORAGE_OBJECT_STORE_H_
#define SKIMAP_STORAGE_OBJECT_STORE_H_

#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "storage/sqlite.h"

namespace skimap::storage {

struct StoredCentroid {
  uint32_t cardinality = 0;
  std::string descriptor;  // packed bits (binary) or little-endian float32 values
  friend bool operator==(const StoredCentroid&, const StoredCentroid&) = default;
};

struct StoredVoxel {
  int32_t kx = 0, ky = 0, kz = 0;  // voxel key in the object frame
  uint32_t evidence = 0;
  std::vector<StoredCentroid> centroids;
  friend bool operator==(const StoredVoxel&, const StoredVoxel&) = default;
};

struct StoredObject {
  int obj_id = 0;
  std::string name;
  int64_t frames = 0, features = 0, descriptors = 0;
  int64_t raw_descriptor_bytes = 0, centroid_bytes = 0;
  std::string rgb_volume;           // SkiMap volume file (docs/formats.md)
  std::vector<StoredVoxel> voxels;  // in rank order
  friend bool operator==(const StoredObject&, const StoredObject&) = default;
};

struct StoredObjectDatabase {
  int format_version = 1;  // of the object database records (not the SQLite schema)
  std::string detector;
  int descriptor_kind = 0;
  int descriptor_dims = 0;
  double resolution = 0;
  int classes_per_object = 0;
  std::map<std::string, std::string> params;  // every training parameter, as text
  std::vector<StoredObject> objects;          // in class-stack order
  int forest_trees = 0, forest_max_depth = 0;
  int64_t forest_classes = 0;
  std::string forest;  // the forest blob; "" = no classifier built
  friend bool operator==(const StoredObjectDatabase&, const StoredObjectDatabase&) = default;
};

// A row of ListObjects.
struct StoredObjectSummary {
  int obj_id = 0;
  std::string name;
  int64_t voxels = 0, centroids = 0, descriptors = 0;
};

class ObjectStore {
 public:
  // Opens or creates the SQLite file and migrates it to the current schema.
  static absl::StatusOr<std::unique_ptr<ObjectStore>> Open(const std::string& path);

  // Replaces the stored object database with `db`, atomically.
  absl::Status Save(const StoredObjectDatabase& db);
  // Reads the whole object database; NotFound if none was saved.
  absl::StatusOr<StoredObjectDatabase> Load();
  // Objects with their sizes, in class-stack order (empty if none).
  absl::StatusOr<std::vector<StoredObjectSummary>> ListObjects();
  // Deletes one object (its voxels and centroids cascade) and the forest, whose classes
  // no longer match; the classifier must be rebuilt. NotFound if absent.
  absl::Status DeleteObject(int obj_id);

 private:
  explicit ObjectStore(std::unique_ptr<Database> db) : db_(std::move(db)) {}
  absl::Status SaveLocked(const StoredObjectDatabase& db);
  absl::StatusOr<StoredObjectDatabase> LoadLocked();

  std::mutex mu_;
  std::unique_ptr<Database> db_;  // guarded by mu_
};

}  // namespace skimap::storage

#endif  // SKIMAP_STORAGE_OBJECT_STORE_H_
