// The MapStore contract (storage/map_store.h), written once and run against every backend
// (TEST_P over backend factories: SQLite, and PostgreSQL on a real server that this binary
// starts from Debian's package, tests/common/postgres_server.h), plus the SQLite backend's
// file behaviour: durability across reopen, newer schema refused, corrupt file.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>

#include "absl/strings/str_cat.h"
#include "storage/fault_injecting_map_store.h"
#include "storage/postgres_map_store.h"
#include "storage/sqlite.h"
#include "storage/sqlite_map_store.h"
#include "tests/common/postgres_server.h"

namespace skimap::storage {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

struct Backend {
  std::string name;
  // Opens the store kept at `dir` (the same dir again reopens the same data).
  std::function<absl::StatusOr<std::unique_ptr<MapStore>>(const std::string& dir)> open;
};

void PrintTo(const Backend& b, std::ostream* os) { *os << b.name; }

// One PostgreSQL server per test process, started on first use and removed at exit; each
// test directory names its own database (the same directory reopens the same database).
absl::StatusOr<std::string> PostgresDsn(const std::string& dir) {
  static skimap::testing::PostgresServer server;
  static const absl::Status started = server.Start();
  if (!started.ok()) return started;
  return server.Dsn(fs::path(dir).filename().string());
}

std::vector<Backend> Backends() {
  return {{"sqlite",
           [](const std::string& dir) -> absl::StatusOr<std::unique_ptr<MapStore>> {
             absl::StatusOr<std::unique_ptr<SqliteMapStore>> s =
                 SqliteMapStore::Open(dir + "/maps.sqlite");
             if (!s.ok()) return s.status();
             return std::unique_ptr<MapStore>(*std::move(s));
           }},
          {"postgres", [](const std::string& dir) -> absl::StatusOr<std::unique_ptr<MapStore>> {
             absl::StatusOr<std::string> dsn = PostgresDsn(dir);
             if (!dsn.ok()) return dsn.status();
             absl::StatusOr<std::unique_ptr<PostgresMapStore>> s = PostgresMapStore::Open(*dsn, {});
             if (!s.ok()) return s.status();
             return std::unique_ptr<MapStore>(*std::move(s));
           }}};
}

class MapStoreConformanceTest : public ::testing::TestWithParam<Backend> {
 protected:
  void SetUp() override {
    dir_ = (fs::temp_directory_path() /
            absl::StrCat("map_store_", GetParam().name, "_", getpid(), "_", ++count_))
               .string();
    fs::create_directories(dir_);
    Reopen();
  }
  void TearDown() override {
    store_.reset();
    fs::remove_all(dir_);
  }
  void Reopen() {
    store_.reset();
    auto s = GetParam().open(dir_);
    ASSERT_TRUE(s.ok()) << s.status();
    store_ = *std::move(s);
  }
  std::vector<JournalRecord> Journal(const std::string& id, uint64_t after = 0) {
    std::vector<JournalRecord> out;
    EXPECT_TRUE(store_
                    ->ReadJournal(id, after, SIZE_MAX,
                                  [&](const JournalRecord& r) {
                                    out.push_back(r);
                                    return absl::OkStatus();
                                  })
                    .ok());
    return out;
  }
  std::map<std::string, std::string> Snapshot(const std::string& id, uint64_t* position) {
    std::map<std::string, std::string> out;
    absl::StatusOr<uint64_t> p = store_->ReadSnapshot(id, [&](const Chunk& c) {
      out[absl::StrCat(c.key.volume, "/", c.key.x, ",", c.key.y, ",", c.key.z)] = c.bytes;
      return absl::OkStatus();
    });
    EXPECT_TRUE(p.ok()) << p.status();
    *position = p.value_or(0);
    return out;
  }

  static inline int count_ = 0;
  std::string dir_;
  std::unique_ptr<MapStore> store_;
};

TEST_P(MapStoreConformanceTest, MapsAreCreatedListedAndDeleted) {
  ASSERT_TRUE(store_->CreateMap("b", "opts-b").ok());
  ASSERT_TRUE(store_->CreateMap("a", std::string("\0bin\xff", 5)).ok());
  EXPECT_EQ(store_->CreateMap("a", "x").code(), absl::StatusCode::kAlreadyExists);
  EXPECT_EQ(store_->CreateMap("", "x").code(), absl::StatusCode::kInvalidArgument);
  absl::StatusOr<std::vector<StoredMap>> maps = store_->ListMaps();
  ASSERT_TRUE(maps.ok());
  ASSERT_EQ(maps->size(), 2u);
  EXPECT_EQ((*maps)[0].id, "a");
  EXPECT_EQ((*maps)[0].options, std::string("\0bin\xff", 5));  // bytes kept exactly
  EXPECT_EQ((*maps)[1].id, "b");
  EXPECT_EQ(store_->GetMap("c").status().code(), absl::StatusCode::kNotFound);
  ASSERT_TRUE(store_->DeleteMap("a").ok());
  EXPECT_EQ(store_->DeleteMap("a").code(), absl::StatusCode::kNotFound);
  EXPECT_EQ(store_->ListMaps()->size(), 1u);
}

TEST_P(MapStoreConformanceTest, JournalRecordsKeepTheirOrderPositionsAndBytes) {
  ASSERT_TRUE(store_->CreateMap("m", "").ok());
  EXPECT_EQ(store_->AppendJournal("m", {}).status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(store_->AppendJournal("nope", {{JournalRecord::kFrame, "x"}}).status().code(),
            absl::StatusCode::kNotFound);
  absl::StatusOr<uint64_t> last = store_->AppendJournal(
      "m", {{JournalRecord::kFrame, "f1"}, {JournalRecord::kFrame, std::string(3 << 20, 'z')}});
  ASSERT_TRUE(last.ok()) << last.status();
  EXPECT_EQ(*last, 2u);
  EXPECT_EQ(*store_->AppendJournal("m", {{JournalRecord::kPoseUpdate, "p3"}}), 3u);
  const std::vector<JournalRecord> all = Journal("m");
  ASSERT_EQ(all.size(), 3u);
  EXPECT_EQ(all[0].position, 1u);
  EXPECT_EQ(all[0].payload, "f1");
  EXPECT_EQ(all[1].payload.size(), size_t(3 << 20));
  EXPECT_EQ(all[2].kind, JournalRecord::kPoseUpdate);
  EXPECT_EQ(Journal("m", 2).size(), 1u);
  EXPECT_EQ(store_->GetMap("m")->last_position, 3u);
  // A limit reads a batch; one record by position.
  size_t batch = 0;
  ASSERT_TRUE(store_
                  ->ReadJournal("m", 0, 2,
                                [&](const JournalRecord&) {
                                  ++batch;
                                  return absl::OkStatus();
                                })
                  .ok());
  EXPECT_EQ(batch, 2u);
  absl::StatusOr<JournalRecord> third = store_->ReadJournalRecord("m", 3);
  ASSERT_TRUE(third.ok()) << third.status();
  EXPECT_EQ(third->payload, "p3");
  EXPECT_EQ(third->kind, JournalRecord::kPoseUpdate);
  EXPECT_EQ(store_->ReadJournalRecord("m", 9).status().code(), absl::StatusCode::kNotFound);
  // Pruning keeps positions: new records continue after the last one.
  ASSERT_TRUE(store_->PruneJournal("m", 2).ok());
  EXPECT_EQ(Journal("m").size(), 1u);
  EXPECT_EQ(store_->ReadJournalRecord("m", 1).status().code(), absl::StatusCode::kNotFound);
  EXPECT_EQ(*store_->AppendJournal("m", {{JournalRecord::kFrame, "f4"}}), 4u);
}

TEST_P(MapStoreConformanceTest, AnAppendedRecordSurvivesReopening) {
  ASSERT_TRUE(store_->CreateMap("m", "o").ok());
  ASSERT_TRUE(store_->AppendJournal("m", {{JournalRecord::kFrame, "kept"}}).ok());
  Reopen();
  const std::vector<JournalRecord> all = Journal("m");
  ASSERT_EQ(all.size(), 1u);
  EXPECT_EQ(all[0].payload, "kept");
  EXPECT_EQ(store_->GetMap("m")->options, "o");
}

TEST_P(MapStoreConformanceTest, SnapshotsReplaceChangedChunksAndDropRemovedOnes) {
  ASSERT_TRUE(store_->CreateMap("m", "").ok());
  ASSERT_TRUE(
      store_->AppendJournal("m", {{JournalRecord::kFrame, "1"}, {JournalRecord::kFrame, "2"}})
          .ok());
  uint64_t position = 99;
  EXPECT_TRUE(Snapshot("m", &position).empty());
  EXPECT_EQ(position, 0u);
  ASSERT_TRUE(store_
                  ->WriteSnapshot(
                      "m", 1,
                      {{{"rgb", 0, 0, 0}, "A"}, {{"rgb", -1, 2, 3}, "B"}, {{"free", 0, 0, 0}, "C"}},
                      {})
                  .ok());
  std::map<std::string, std::string> chunks = Snapshot("m", &position);
  EXPECT_EQ(position, 1u);
  EXPECT_EQ(chunks, (std::map<std::string, std::string>{
                        {"rgb/0,0,0", "A"}, {"rgb/-1,2,3", "B"}, {"free/0,0,0", "C"}}));
  ASSERT_TRUE(store_->WriteSnapshot("m", 2, {{{"rgb", 0, 0, 0}, "A2"}}, {{"free", 0, 0, 0}}).ok());
  chunks = Snapshot("m", &position);
  EXPECT_EQ(position, 2u);
  EXPECT_EQ(chunks, (std::map<std::string, std::string>{{"rgb/0,0,0", "A2"}, {"rgb/-1,2,3", "B"}}));
  EXPECT_GT(store_->GetMap("m")->snapshot_unix_ms, 0);
  // A snapshot behind the last one or beyond the journal is refused and changes nothing.
  EXPECT_EQ(store_->WriteSnapshot("m", 1, {{{"rgb", 9, 9, 9}, "X"}}, {}).code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(store_->WriteSnapshot("m", 3, {{{"rgb", 9, 9, 9}, "X"}}, {}).code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(Snapshot("m", &position), chunks);
  EXPECT_EQ(position, 2u);
}

TEST_P(MapStoreConformanceTest, DeletingAMapDeletesItsJournalAndChunks) {
  ASSERT_TRUE(store_->CreateMap("m", "").ok());
  ASSERT_TRUE(store_->AppendJournal("m", {{JournalRecord::kFrame, "1"}}).ok());
  ASSERT_TRUE(store_->WriteSnapshot("m", 1, {{{"rgb", 0, 0, 0}, "A"}}, {}).ok());
  ASSERT_TRUE(store_->DeleteMap("m").ok());
  ASSERT_TRUE(store_->CreateMap("m", "").ok());  // the same id starts empty
  EXPECT_TRUE(Journal("m").empty());
  uint64_t position = 0;
  EXPECT_TRUE(Snapshot("m", &position).empty());
  EXPECT_EQ(store_->GetMap("m")->last_position, 0u);
}

TEST_P(MapStoreConformanceTest, AnImportContinuesTheJournalAfterItsBaseAndIsMarkedUntilFinished) {
  ASSERT_TRUE(store_->CreateMap("taken", "").ok());
  EXPECT_EQ(store_->BeginImport("taken", "o", 5).code(), absl::StatusCode::kAlreadyExists);
  EXPECT_EQ(store_->BeginImport("", "o", 5).code(), absl::StatusCode::kInvalidArgument);
  ASSERT_TRUE(store_->BeginImport("m", "opts", 40).ok());
  absl::StatusOr<StoredMap> m = store_->GetMap("m");
  ASSERT_TRUE(m.ok()) << m.status();
  EXPECT_TRUE(m->importing);
  EXPECT_EQ(m->last_position, 40u);
  EXPECT_EQ(m->options, "opts");
  EXPECT_FALSE(store_->GetMap("taken")->importing);
  // A snapshot may cover the base; positions up to it read as pruned.
  ASSERT_TRUE(store_->WriteSnapshot("m", 0, {{{"rgb", 0, 0, 0}, "A"}}, {}).ok());
  ASSERT_TRUE(store_->WriteSnapshot("m", 40, {}, {}).ok());
  EXPECT_EQ(store_->ReadJournalRecord("m", 40).status().code(), absl::StatusCode::kNotFound);
  EXPECT_EQ(*store_->AppendJournal("m", {{JournalRecord::kFrame, "f41"}}), 41u);
  EXPECT_EQ(store_->ReadJournalRecord("m", 41)->payload, "f41");
  Reopen();  // the mark is durable
  EXPECT_TRUE(store_->ListMaps()->at(0).importing);
  ASSERT_TRUE(store_->FinishImport("m").ok());
  EXPECT_FALSE(store_->GetMap("m")->importing);
  EXPECT_EQ(store_->GetMap("m")->snapshot_position, 40u);
  EXPECT_EQ(store_->FinishImport("nope").code(), absl::StatusCode::kNotFound);
}

TEST_P(MapStoreConformanceTest, SnapshotPagesWalkEveryChunkOnceInKeyOrder) {
  ASSERT_TRUE(store_->CreateMap("m", "").ok());
  ASSERT_TRUE(store_->CreateMap("other", "").ok());
  ASSERT_TRUE(store_->AppendJournal("m", {{JournalRecord::kFrame, "1"}}).ok());
  std::vector<Chunk> chunks;
  for (const char* volume : {"rgb", "free", "frames"}) {
    for (int64_t x : {-3, 0, 2}) {
      for (int64_t z : {-1, 7}) chunks.push_back({{volume, x, 1, z}, absl::StrCat(volume, x, z)});
    }
  }
  ASSERT_TRUE(store_->WriteSnapshot("m", 1, chunks, {}).ok());
  ASSERT_TRUE(store_->WriteSnapshot("other", 0, {{{"rgb", 0, 0, 0}, "O"}}, {}).ok());
  for (size_t limit : {1, 4, 100}) {
    SCOPED_TRACE(limit);
    std::vector<ChunkKey> keys;
    std::optional<ChunkKey> after;
    for (;;) {
      size_t n = 0;
      absl::StatusOr<uint64_t> covered =
          store_->ReadSnapshotPage("m", after, limit, [&](const Chunk& c) {
            EXPECT_EQ(c.bytes, absl::StrCat(c.key.volume, c.key.x, c.key.z));
            keys.push_back(c.key);
            ++n;
            return absl::OkStatus();
          });
      ASSERT_TRUE(covered.ok()) << covered.status();
      EXPECT_EQ(*covered, 1u);
      EXPECT_LE(n, limit);
      if (n == 0) break;
      after = keys.back();
    }
    ASSERT_EQ(keys.size(), chunks.size());
    EXPECT_TRUE(std::is_sorted(keys.begin(), keys.end()));
    EXPECT_EQ(std::adjacent_find(keys.begin(), keys.end()), keys.end());
  }
  EXPECT_EQ(
      store_
          ->ReadSnapshotPage("nope", std::nullopt, 1, [](const Chunk&) { return absl::OkStatus(); })
          .status()
          .code(),
      absl::StatusCode::kNotFound);
}

TEST_P(MapStoreConformanceTest, AFailedWriteChangesNothingAndWritesSucceedAfterIt) {
  // For every N: the N-th write of a fixed sequence fails; the store then holds exactly
  // what the successful writes made, and the sequence completes on retry.
  for (int n = 1; n <= 5; ++n) {
    SCOPED_TRACE(n);
    TearDown();
    SetUp();
    FaultInjectingMapStore faulty(std::move(store_));
    faulty.FailWriteNumber(n, absl::UnavailableError("injected"));
    std::vector<std::string> acked;
    auto run = [&](int i) -> absl::Status {
      switch (i) {
        case 0:
          return faulty.CreateMap("m", "");
        case 4: {
          const std::vector<Chunk> chunks = {Chunk{ChunkKey{"rgb", 0, 0, 0}, "A"}};
          return faulty.WriteSnapshot("m", 1, chunks, {});
        }
        default: {
          absl::StatusOr<uint64_t> p =
              faulty.AppendJournal("m", {{JournalRecord::kFrame, absl::StrCat("f", i)}});
          if (p.ok()) acked.push_back(absl::StrCat("f", i));
          return p.status();
        }
      }
    };
    for (int i = 0; i < 5; ++i) {
      absl::Status s = run(i);
      if (i + 1 == n) {
        EXPECT_EQ(s.code(), absl::StatusCode::kUnavailable);
        s = run(i);  // the retry succeeds
      }
      ASSERT_TRUE(s.ok()) << s;
    }
    std::vector<std::string> journal;
    ASSERT_TRUE(faulty
                    .ReadJournal("m", 0, SIZE_MAX,
                                 [&](const JournalRecord& r) {
                                   journal.push_back(r.payload);
                                   return absl::OkStatus();
                                 })
                    .ok());
    EXPECT_EQ(journal, acked);  // every acknowledged append, nothing else
    EXPECT_EQ(faulty.writes(), 6);
  }
}

INSTANTIATE_TEST_SUITE_P(Backends, MapStoreConformanceTest, ::testing::ValuesIn(Backends()),
                         [](const ::testing::TestParamInfo<Backend>& info) {
                           return info.param.name;
                         });

TEST(SqliteMapStoreTest, TheJournalIsWrittenAheadInWalMode) {
  const std::string dir =
      (fs::temp_directory_path() / absl::StrCat("map_store_wal_", getpid())).string();
  fs::create_directories(dir);
  auto s = SqliteMapStore::Open(dir + "/maps.sqlite");
  ASSERT_TRUE(s.ok());
  ASSERT_TRUE((*s)->CreateMap("m", "").ok());
  ASSERT_TRUE((*s)->AppendJournal("m", {{JournalRecord::kFrame, "f"}}).ok());
  EXPECT_TRUE(fs::exists(dir + "/maps.sqlite-wal"));
  s->reset();
  fs::remove_all(dir);
}

TEST(SqliteMapStoreTest, AFileOfANewerSchemaIsRefused) {
  const std::string dir =
      (fs::temp_directory_path() / absl::StrCat("map_store_new_", getpid())).string();
  fs::create_directories(dir);
  const std::string path = dir + "/maps.sqlite";
  ASSERT_TRUE(SqliteMapStore::Open(path).ok());
  {
    auto db = Database::Open(path);
    ASSERT_TRUE(db.ok());
    ASSERT_TRUE((*db)
                    ->Exec("INSERT INTO schema_version (version, name, applied_unix_s) "
                           "VALUES (99, 'from the future', 0)")
                    .ok());
  }
  absl::StatusOr<std::unique_ptr<SqliteMapStore>> s = SqliteMapStore::Open(path);
  EXPECT_EQ(s.status().code(), absl::StatusCode::kFailedPrecondition) << s.status();
  fs::remove_all(dir);
}

TEST(SqliteMapStoreTest, ACorruptFileIsAnErrorNotACrash) {
  const std::string dir =
      (fs::temp_directory_path() / absl::StrCat("map_store_bad_", getpid())).string();
  fs::create_directories(dir);
  const std::string path = dir + "/maps.sqlite";
  std::ofstream(path, std::ios::binary) << std::string(8192, '\x5a');
  absl::StatusOr<std::unique_ptr<SqliteMapStore>> s = SqliteMapStore::Open(path);
  EXPECT_FALSE(s.ok());
  EXPECT_THAT(s.status().code(),
              ::testing::AnyOf(absl::StatusCode::kDataLoss, absl::StatusCode::kUnavailable));
  fs::remove_all(dir);
}

}  // namespace
}  // namespace skimap::storage
