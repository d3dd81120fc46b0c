// Persistence of an ObjectDatabase in the server's SQLite file (storage/object_store.h):
// objects, voxels (rank order), centroids, the forest blob, every training parameter and
// the format version. Loading validates everything (ObjectDatabase::Create), so a loaded
// database is identical to the saved one and safe to use.
//
//   RETURN_IF_ERROR(SaveObjectDatabase(db, "/var/lib/skimap/skimap.db"));
//   absl::StatusOr<ObjectDatabase> db = LoadObjectDatabase("/var/lib/skimap/skimap.db");
//
// Thread safety: reentrant; concurrent calls on one file are serialized by SQLite.
#ifndef SERVER_CORE_OBJECTS_OBJECT_DATABASE_IO_H_
#define SERVER_CORE_OBJECTS_OBJECT_DATABASE_IO_H_

#include <string>

#include "absl/status/statusor.h"
#include "perception/objects/object_database.h"
#include "storage/object_store.h"

namespace skimap::objects {

// The database as storage records (and back). FromStoredRecords: InvalidArgument /
// DataLoss for inconsistent records (wrong descriptor sizes, bad forest blob, ...).
storage::StoredObjectDatabase ToStoredRecords(const ObjectDatabase& db);
absl::StatusOr<ObjectDatabase> FromStoredRecords(const storage::StoredObjectDatabase& records);

// Saves into (creating or migrating) the SQLite file at `path`, replacing the object
// database stored there.
absl::Status SaveObjectDatabase(const ObjectDatabase& db, const std::string& path);
// Loads from the SQLite file at `path`; NotFound if none was saved there.
absl::StatusOr<ObjectDatabase> LoadObjectDatabase(const std::string& path);

// The training parameters as text (key -> value; doubles with 17 significant digits),
// and back (InvalidArgument naming the key for a missing or malformed value).
std::map<std::string, std::string> ParamsToText(const ObjectDatabaseParams& params);
absl::StatusOr<ObjectDatabaseParams> ParamsFromText(const std::map<std::string, std::string>& text);

}  // namespace skimap::objects

#endif  // SERVER_CORE_OBJECTS_OBJECT_DATABASE_IO_H_
