// The storage schema: every migration of the SkiMap server's SQLite database, oldest
// first (docs/objects.md lists the object database tables). Append new migrations; never
// edit a released one.
//
// Thread safety: constant data.
#ifndef SKIMAP_STORAGE_SCHEMA_H_
#define SKIMAP_STORAGE_SCHEMA_H_

#include <span>

#include "storage/migrations.h"

namespace skimap::storage {

// All migrations, version 1..N.
std::span<const Migration> StorageMigrations();

}  // namespace skimap::storage

#endif  // SKIMAP_STORAGE_SCHEMA_H_
