// SQLite layer, schema migrations and the object store, on real database files in
// temporary directories.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "storage/migrations.h"
#include "storage/object_store.h"
#include "storage/schema.h"
#include "storage/sqlite.h"
#include "storage/sqlite_map_store.h"
#include "tests/common/test_temp_dir.h"

namespace skimap::storage {
namespace {
namespace fs = std::filesystem;

std::string TempDir() { return skimap::testing::TestTempDir("skimap_storage"); }

int64_t PageSize(const std::string& path) {
  auto db = Database::Open(path);
  EXPECT_TRUE(db.ok()) << db.status();
  auto st = (*db)->Prepare("PRAGMA page_size");
  EXPECT_TRUE(st.ok()) << st.status();
  auto row = st->Step();
  EXPECT_TRUE(row.ok() && *row);
  return st->ColumnInt(0);
}

StoredObjectDatabase SampleRecords() {
  StoredObjectDatabase db;
  db.detector = "ORB";
  db.descriptor_kind = 1;
  db.descriptor_dims = 256;
  db.resolution = 0.01;
  db.classes_per_object = 2;
  db.params = {{"detector", "ORB"}, {"resolution", "0.01"}};
  for (int id : {7, 3}) {  // stack order differs from obj_id order
    StoredObject o{.obj_id = id,
                   .name = "obj" + std::to_string(id),
                   .frames = 10,
                   .features = 100,
                   .descriptors = 90,
                   .raw_descriptor_bytes = 2880,
                   .centroid_bytes = 400,
                   .rgb_volume = std::string("\0rgb\xff", 5)};
    for (int r = 0; r < 3; ++r) {
      StoredVoxel v{r, -r, id, static_cast<uint32_t>(30 - r), {}};
      for (int c = 0; c <= r; ++c)
        v.centroids.push_back({static_cast<uint32_t>(c + 1), std::string(32, char('a' + c))});
      o.voxels.push_back(v);
    }
    db.objects.push_back(o);
  }
  db.forest_trees = 24;
  db.forest_max_depth = 24;
  db.forest_classes = 4;
  db.forest = std::string("SKRF\0\x01", 6);
  return db;
}

TEST(SqliteTest, StatementsBindAndReadEveryType) {
  auto db = Database::Open(TempDir() + "/t.db");
  ASSERT_TRUE(db.ok()) << db.status();
  ASSERT_TRUE((*db)->Exec("CREATE TABLE t (i INTEGER, d REAL, s TEXT, b BLOB);").ok());
  auto ins = (*db)->Prepare("INSERT INTO t VALUES (?, ?, ?, ?)");
  ASSERT_TRUE(ins.ok());
  ASSERT_TRUE(ins->BindInt(1, -(int64_t{1} << 40)).ok());
  ASSERT_TRUE(ins->BindDouble(2, 0.1).ok());
  ASSERT_TRUE(ins->BindText(3, "héllo").ok());
  ASSERT_TRUE(ins->BindBlob(4, std::string("\0\1\2", 3)).ok());
  ASSERT_TRUE(ins->Run().ok());
  auto sel = (*db)->Prepare("SELECT i, d, s, b FROM t");
  ASSERT_TRUE(sel.ok());
  ASSERT_TRUE(*sel->Step());
  EXPECT_EQ(sel->ColumnInt(0), -(int64_t{1} << 40));
  EXPECT_EQ(sel->ColumnDouble(1), 0.1);
  EXPECT_EQ(sel->ColumnText(2), "héllo");
  EXPECT_EQ(sel->ColumnBlob(3), std::string("\0\1\2", 3));
  EXPECT_FALSE(*sel->Step());
  EXPECT_FALSE((*db)->Prepare("SELEKT nonsense").ok());
}

TEST(SqliteTest, TransactionRollsBackUnlessCommitted) {
  auto db = Database::Open(":memory:");
  ASSERT_TRUE(db.ok());
  ASSERT_TRUE((*db)->Exec("CREATE TABLE t (x INTEGER);").ok());
  {
    Transaction tx(**db);
    ASSERT_TRUE(tx.status().ok());
    ASSERT_TRUE((*db)->Exec("INSERT INTO t VALUES (1);").ok());
  }
  auto count = (*db)->Prepare("SELECT COUNT(*) FROM t");
  ASSERT_TRUE(*count->Step());
  EXPECT_EQ(count->ColumnInt(0), 0);
}

TEST(MigrationsTest, FreshFileReachesTheNewestVersionOnce) {
  const std::string path = TempDir() + "/m.db";
  for (int round = 0; round < 2; ++round) {
    auto db = Database::Open(path);
    ASSERT_TRUE(db.ok());
    ASSERT_TRUE(Migrate(**db, StorageMigrations()).ok());
    auto v = SchemaVersion(**db);
    ASSERT_TRUE(v.ok());
    EXPECT_EQ(*v, static_cast<int>(StorageMigrations().size()));
  }
}

TEST(MigrationsTest, NewerDatabaseAndBrokenListsAreRefused) {
  auto db = Database::Open(TempDir() + "/m.db");
  ASSERT_TRUE(db.ok());
  const Migration two[] = {{1, "a", "CREATE TABLE a (x);"}, {2, "b", "CREATE TABLE b (x);"}};
  ASSERT_TRUE(Migrate(**db, two).ok());
  const Migration one[] = {{1, "a", "CREATE TABLE a (x);"}};
  EXPECT_EQ(Migrate(**db, one).code(), absl::StatusCode::kFailedPrecondition);
  const Migration gap[] = {{1, "a", ""}, {3, "c", ""}};
  EXPECT_EQ(Migrate(**db, gap).code(), absl::StatusCode::kFailedPrecondition);
  // A failing step is rolled back and leaves the version unchanged.
  const Migration bad[] = {two[0], two[1], {3, "bad", "CREATE TABLE c (x); SYNTAX ERROR;"}};
  EXPECT_FALSE(Migrate(**db, bad).ok());
  EXPECT_EQ(*SchemaVersion(**db), 2);
  EXPECT_TRUE((*db)->Exec("CREATE TABLE c (x);").ok());  // c was not left behind
}

TEST(ObjectStoreTest, SaveLoadRoundTripAndReplace) {
  const std::string path = TempDir() + "/objects.db";
  const StoredObjectDatabase records = SampleRecords();
  {
    auto store = ObjectStore::Open(path);
    ASSERT_TRUE(store.ok()) << store.status();
    EXPECT_EQ((*store)->Load().status().code(), absl::StatusCode::kNotFound);
    ASSERT_TRUE((*store)->Save(records).ok());
    ASSERT_TRUE((*store)->Save(records).ok());  // replaces, no duplicate rows
  }
  auto store = ObjectStore::Open(path);  // reopened from disk
  ASSERT_TRUE(store.ok());
  auto back = (*store)->Load();
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(*back, records);
  auto list = (*store)->ListObjects();
  ASSERT_TRUE(list.ok());
  ASSERT_EQ(list->size(), 2u);
  EXPECT_EQ((*list)[0].obj_id, 7);
  EXPECT_EQ((*list)[0].voxels, 3);
  EXPECT_EQ((*list)[0].centroids, 6);
}

TEST(ObjectStoreTest, DeleteObjectCascadesAndDropsTheForest) {
  auto store = ObjectStore::Open(TempDir() + "/objects.db");
  ASSERT_TRUE(store.ok());
  ASSERT_TRUE((*store)->Save(SampleRecords()).ok());
  ASSERT_TRUE((*store)->DeleteObject(7).ok());
  EXPECT_EQ((*store)->DeleteObject(7).code(), absl::StatusCode::kNotFound);
  auto back = (*store)->Load();
  ASSERT_TRUE(back.ok());
  ASSERT_EQ(back->objects.size(), 1u);
  EXPECT_EQ(back->objects[0].obj_id, 3);
  EXPECT_EQ(back->objects[0].voxels.size(), 3u);
  EXPECT_TRUE(back->forest.empty());
}

TEST(ObjectStoreTest, NotADatabaseIsAnError) {
  const std::string path = TempDir() + "/garbage.db";
  std::ofstream(path) << std::string(4096, 'x');
  auto store = ObjectStore::Open(path);
  EXPECT_FALSE(store.ok());
  EXPECT_EQ(store.status().code(), absl::StatusCode::kDataLoss) << store.status();
}

// storage/sqlite_map_store.cc: journal payloads are ~1 MB blobs, so a new maps file gets
// 64 KiB pages; a file made with another page size keeps it and works as before.
TEST(SqliteMapStoreTest, ANewFileHas64KiBPagesAndAnOldFileKeepsItsOwn) {
  const std::string fresh = TempDir() + "/fresh_maps.sqlite";
  {
    auto store = SqliteMapStore::Open(fresh);
    ASSERT_TRUE(store.ok()) << store.status();
    ASSERT_TRUE((*store)->CreateMap("m", "options").ok());
  }
  EXPECT_EQ(PageSize(fresh), 65536);

  const std::string old = TempDir() + "/old_maps.sqlite";
  {
    auto db = Database::Open(old);
    ASSERT_TRUE(db.ok()) << db.status();
    ASSERT_TRUE((*db)->Exec("PRAGMA page_size=4096; CREATE TABLE earlier (a INTEGER);").ok());
  }
  {
    auto store = SqliteMapStore::Open(old);
    ASSERT_TRUE(store.ok()) << store.status();
    ASSERT_TRUE((*store)->CreateMap("m", "options").ok());
    auto maps = (*store)->ListMaps();
    ASSERT_TRUE(maps.ok()) << maps.status();
    EXPECT_EQ(maps->size(), 1u);
  }
  EXPECT_EQ(PageSize(old), 4096);
}

}  // namespace
}  // namespace skimap::storage
