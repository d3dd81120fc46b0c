#include "storage/schema.h"

namespace skimap::storage {
namespace {

// Version 1: the object database (perception/objects; paper §3).
constexpr char kObjectDatabaseV1[] = R"sql(
CREATE TABLE object_db (
  id INTEGER PRIMARY KEY CHECK (id = 1),
  format_version INTEGER NOT NULL,
  detector TEXT NOT NULL,
  descriptor_kind INTEGER NOT NULL,
  descriptor_dims INTEGER NOT NULL,
  resolution REAL NOT NULL,
  classes_per_object INTEGER NOT NULL,
  saved_unix_s INTEGER NOT NULL
);
CREATE TABLE training_params (
  key TEXT PRIMARY KEY,
  value TEXT NOT NULL
) WITHOUT ROWID;
CREATE TABLE objects (
  obj_id INTEGER PRIMARY KEY,
  stack_index INTEGER NOT NULL UNIQUE,
  name TEXT NOT NULL,
  frames INTEGER NOT NULL,
  features INTEGER NOT NULL,
  descriptors INTEGER NOT NULL,
  raw_descriptor_bytes INTEGER NOT NULL,
  centroid_bytes INTEGER NOT NULL,
  rgb_volume BLOB NOT NULL
);
CREATE TABLE voxels (
  obj_id INTEGER NOT NULL REFERENCES objects(obj_id) ON DELETE CASCADE,
  rank INTEGER NOT NULL,
  kx INTEGER NOT NULL,
  ky INTEGER NOT NULL,
  kz INTEGER NOT NULL,
  evidence INTEGER NOT NULL,
  PRIMARY KEY (obj_id, rank)
) WITHOUT ROWID;
CREATE TABLE centroids (
  obj_id INTEGER NOT NULL,
  rank INTEGER NOT NULL,
  idx INTEGER NOT NULL,
  cardinality INTEGER NOT NULL,
  descriptor BLOB NOT NULL,
  PRIMARY KEY (obj_id, rank, idx),
  FOREIGN KEY (obj_id, rank) REFERENCES voxels(obj_id, rank) ON DELETE CASCADE
) WITHOUT ROWID;
CREATE TABLE forest (
  id INTEGER PRIMARY KEY CHECK (id = 1),
  trees INTEGER NOT NULL,
  max_depth INTEGER NOT NULL,
  num_classes INTEGER NOT NULL,
  model BLOB NOT NULL
);
)sql";

// Version 2: the raw training descriptors of each object's voxels, so that the object
// service can rebuild the classifier (the forest trains on raw descriptors) after a
// restart or a delete. No foreign key to objects: ObjectStore::Save rewrites that table.
constexpr char kTrainingDescriptorsV2[] = R"sql(
CREATE TABLE training_descriptors (
  obj_id INTEGER NOT NULL,
  rank INTEGER NOT NULL,
  descriptors BLOB NOT NULL,
  PRIMARY KEY (obj_id, rank)
) WITHOUT ROWID;
)sql";

constexpr Migration kMigrations[] = {
    {1, "object database: object_db, training_params, objects, voxels, centroids, forest",
     kObjectDatabaseV1},
    {2, "training_descriptors: raw descriptors per object voxel", kTrainingDescriptorsV2},
};

}  // namespace

std::span<const Migration> StorageMigrations() { return kMigrations; }

}  // namespace skimap::storage
