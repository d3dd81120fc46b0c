// Export and import of maps through real skimapd processes, real gRPC and real files: the
// copy equals the original voxel by voxel (with and without the journal, in the same or
// another server), damaged files are refused with DATA_LOSS and leave nothing behind, and
// the `skimap export` / `skimap import` commands work end to end.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <future>
#include <set>
#include <sstream>
#include <thread>
#include <tuple>

#include "client/map_client.h"
#include "server/app/server.h"
#include "server/core/transfer/map_export.h"
#include "server/core/transfer/map_transfer.h"
#include "storage/sqlite_map_store.h"
#include "tests/common/skimapd_process.h"
#include "tests/common/synthetic_scene.h"
#include "tests/common/voxel_set.h"

namespace skimap::testing {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

// VGA frames: six of them make a journal of several 1 MiB pieces.
const SyntheticCamera kVga{
    .width = 640, .height = 480, .fx = 480, .fy = 480, .cx = 319.5, .cy = 239.5};

Eigen::Isometry3d View(int i) {
  Eigen::Isometry3d pose = DefaultView();
  pose.translation().y() += 0.07 * i;
  return pose;
}

v1::UpdatePosesRequest Moved(const std::string& map, std::initializer_list<int> sequences) {
  v1::UpdatePosesRequest update;
  update.set_map(map);
  for (int i : sequences) {
    v1::PoseUpdate* u = update.add_updates();
    u->set_sequence(i);
    Eigen::Isometry3d moved = View(i);
    moved.translation().x() += 0.11;
    SetPose(moved, u->mutable_pose());
  }
  return update;
}

std::string Grid(client::MapClient& client, const std::string& map) {
  v1::GetOccupancyGridRequest request;
  request.set_map(map);
  // The volumes only: the views that clear seen-through obstacles are not persisted
  // (server/core/maps/grid_views.h).
  request.set_keep_seen_through(true);
  auto grid = client.GetOccupancyGrid(request);
  EXPECT_TRUE(grid.ok()) << grid.status();
  return grid.ok() ? grid->SerializeAsString() : "";
}

// maps/{id}: carving on, six VGA frames, one pose update of frames 1 and 4.
void MakeMap(client::MapClient& client, const std::string& id) {
  v1::CreateMapRequest create;
  create.set_map_id(id);
  create.mutable_options()->set_resolution(0.04);
  create.mutable_options()->set_carve_free_space(true);
  ASSERT_TRUE(client.CreateMap(create).ok());
  const std::string name = "maps/" + id;
  std::unique_ptr<client::FrameStream> stream = client.OpenFrameStream({.window = 4});
  for (int i = 0; i < 6; ++i) ASSERT_TRUE(stream->Send(MakeFrame(name, i, View(i), kVga)).ok());
  auto acks = stream->Finish();
  ASSERT_TRUE(acks.ok());
  for (const v1::FrameAck& a : *acks) ASSERT_EQ(a.code(), 0) << a.message();
  ASSERT_TRUE(client.UpdatePoses(Moved(name, {1, 4})).ok());
}

// The export file of `name`, received piece by piece; `pieces` counts them.
std::string Export(client::MapClient& client, const std::string& name, bool with_journal,
                   int* pieces = nullptr) {
  v1::ExportMapRequest request;
  request.set_name(name);
  request.set_with_journal(with_journal);
  std::string file;
  absl::Status s = client.ExportMap(request, [&](std::string_view piece) {
    EXPECT_LE(piece.size(), size_t{1} << 20);
    EXPECT_FALSE(piece.empty());
    if (pieces != nullptr) ++*pieces;
    file.append(piece);
    return absl::OkStatus();
  });
  EXPECT_TRUE(s.ok()) << s;
  return file;
}

// Sends `file` in pieces of 100 KB.
absl::StatusOr<v1::Map> Import(client::MapClient& client, const std::string& file,
                               const std::string& as_id) {
  size_t at = 0;
  return client.ImportMap(as_id, [&]() -> absl::StatusOr<std::string> {
    std::string piece = file.substr(at, 100000);
    at += piece.size();
    return piece;
  });
}

class ExportImportTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = (fs::temp_directory_path() /
            absl::StrCat("skimap_export_test_", getpid(), "_",
                         ::testing::UnitTest::GetInstance()->current_test_info()->name()))
               .string();
    fs::create_directories(dir_);
    ASSERT_TRUE(server_.Start().ok());
    client_ = client::MapClient::Connect(server_.address());
  }
  void TearDown() override { fs::remove_all(dir_); }

  // Writes `bytes` to a file of the test's dir and reads it back.
  std::string ThroughFile(const std::string& name, const std::string& bytes) {
    const std::string path = dir_ + "/" + name;
    std::ofstream(path, std::ios::binary) << bytes;
    std::ifstream in(path, std::ios::binary);
    std::stringstream all;
    all << in.rdbuf();
    return all.str();
  }

  std::string dir_;
  SkimapdProcess server_{SKIMAPD_PATH, {"--worker_threads=1"}};
  std::unique_ptr<client::MapClient> client_;
};

TEST_F(ExportImportTest, WithTheJournalTheCopyIsEqualAndUpdatePosesWorksOnIt) {
  MakeMap(*client_, "src");
  int pieces = 0;
  const std::string file =
      ThroughFile("src.skmx", Export(*client_, "maps/src", /*with_journal=*/true, &pieces));
  EXPECT_GT(pieces, 2);  // six VGA frames: several MiB
  absl::StatusOr<v1::Map> copy = Import(*client_, file, "copy");
  ASSERT_TRUE(copy.ok()) << copy.status();
  EXPECT_EQ(copy->name(), "maps/copy");
  const v1::Map src = *client_->GetMap("maps/src");
  EXPECT_EQ(copy->stats().frames(), 6u);
  EXPECT_EQ(copy->stats().journal_position(), 7u);  // six frames and one pose update
  EXPECT_EQ(copy->stats().free_voxels(), src.stats().free_voxels());
  EXPECT_GT(copy->stats().free_voxels(), 0u);
  EXPECT_DOUBLE_EQ(copy->options().resolution(), 0.04);
  EXPECT_TRUE(copy->options().carve_free_space());
  const VoxelSet before = Voxels(*client_, "maps/src");
  ASSERT_GT(before.size(), 500u);
  EXPECT_EQ(Voxels(*client_, "maps/copy"), before);
  EXPECT_EQ(Grid(*client_, "maps/copy"), Grid(*client_, "maps/src"));
  // The journal came along at its positions: a pose update reaches the imported frames
  // and moves both maps the same way.
  ASSERT_TRUE(client_->UpdatePoses(Moved("maps/src", {2, 4})).ok());
  auto moved = client_->UpdatePoses(Moved("maps/copy", {2, 4}));
  ASSERT_TRUE(moved.ok()) << moved.status();
  const VoxelSet after = Voxels(*client_, "maps/src");
  EXPECT_NE(after, before);
  EXPECT_EQ(Voxels(*client_, "maps/copy"), after);
  // The copy is an ordinary map on disk: it survives kill -9.
  ASSERT_TRUE(server_.CrashAndRestart().ok());
  client_ = client::MapClient::Connect(server_.address());
  EXPECT_EQ(Voxels(*client_, "maps/copy"), after);
  EXPECT_EQ(client_->GetMap("maps/copy")->stats().frames(), 6u);
}

TEST_F(ExportImportTest, WithoutTheJournalAnotherServerGetsTheSameVolumes) {
  MakeMap(*client_, "src");
  const std::string lean = ThroughFile("lean.skmx", Export(*client_, "maps/src", false));
  const std::string full = Export(*client_, "maps/src", true);
  EXPECT_LT(lean.size() * 3, full.size());  // the frames are most of it
  SkimapdProcess other(SKIMAPD_PATH, {"--worker_threads=1"});
  ASSERT_TRUE(other.Start().ok());
  auto there = client::MapClient::Connect(other.address());
  absl::StatusOr<v1::Map> copy = Import(*there, lean, "");  // keeps the file's id
  ASSERT_TRUE(copy.ok()) << copy.status();
  EXPECT_EQ(copy->name(), "maps/src");
  EXPECT_EQ(copy->stats().frames(), 6u);
  EXPECT_EQ(copy->stats().journal_position(), 7u);  // positions carry over
  EXPECT_EQ(copy->stats().pruned_position(), 7u);   // ... with no record behind them
  EXPECT_EQ(Voxels(*there, "maps/src"), Voxels(*client_, "maps/src"));
  EXPECT_EQ(Grid(*there, "maps/src"), Grid(*client_, "maps/src"));
  // The frames came without their records: they count as pruned. The sequences are known,
  // and new frames go on after the imported positions.
  const auto without_record = there->UpdatePoses(Moved("maps/src", {1}));
  EXPECT_EQ(without_record.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(std::string(without_record.status().message()),
              HasSubstr("left out of an export made without its journal"));
  EXPECT_EQ(there->IntegrateFrame(MakeFrame("maps/src", 3, View(3), kVga)).status().code(),
            absl::StatusCode::kAlreadyExists);
  ASSERT_TRUE(there->IntegrateFrame(MakeFrame("maps/src", 6, View(6), kVga)).ok());
  EXPECT_EQ(there->GetMap("maps/src")->stats().journal_position(), 8u);
  auto moved = there->UpdatePoses(Moved("maps/src", {6}));
  ASSERT_TRUE(moved.ok()) << moved.status();
  const VoxelSet later = Voxels(*there, "maps/src");
  ASSERT_TRUE(other.CrashAndRestart().ok());
  there = client::MapClient::Connect(other.address());
  EXPECT_EQ(Voxels(*there, "maps/src"), later);
}

TEST_F(ExportImportTest, DamagedFilesAreDataLossAndLeaveNothingBehind) {
  MakeMap(*client_, "src");
  const std::string file = Export(*client_, "maps/src", true);
  ASSERT_GT(file.size(), 1000u);
  auto flipped = [&](size_t at) {
    std::string bad = file;
    bad[at] = static_cast<char>(bad[at] ^ 0x20);
    return bad;
  };
  const std::vector<std::pair<std::string, std::string>> damaged = {
      {"flip in the map record", flipped(30)},
      {"flip a third in", flipped(file.size() / 3)},
      {"flip in the middle", flipped(file.size() / 2)},
      {"flip in the end record", flipped(file.size() - 10)},
      {"cut after the header", file.substr(0, 40)},
      {"cut in the middle", file.substr(0, file.size() / 2)},
      {"cut one byte short", file.substr(0, file.size() - 1)},
  };
  for (const auto& [what, bad] : damaged) {
    SCOPED_TRACE(what);
    absl::StatusOr<v1::Map> copy = Import(*client_, ThroughFile("bad.skmx", bad), "copy");
    EXPECT_EQ(copy.status().code(), absl::StatusCode::kDataLoss) << copy.status();
    EXPECT_THAT(copy.status().message(), HasSubstr("export file: "));
    EXPECT_THAT(copy.status().message(), HasSubstr("offset"));
    EXPECT_EQ(client_->GetMap("maps/copy").status().code(), absl::StatusCode::kNotFound);
    EXPECT_EQ(client_->ListAllMaps()->size(), 1u);
  }
  // Every checksum right, one chunk's blob corrupt: the load refuses it, naming the chunk.
  std::string bad_chunk;
  {
    server::ExportReader reader;
    reader.Feed(file);
    std::optional<server::ExportWriter> writer;
    bool damaged_one = false;
    for (;;) {
      auto record = reader.Next();
      ASSERT_TRUE(record.ok()) << record.status();
      if (!record->has_value()) break;
      if (auto* map = std::get_if<server::ExportedMap>(&**record)) writer.emplace(*map, &bad_chunk);
      if (auto* chunk = std::get_if<storage::Chunk>(&**record)) {
        if (!damaged_one && chunk->key.volume == "rgb") {
          chunk->bytes[chunk->bytes.size() / 2] ^= 0x01;
          damaged_one = true;
        }
        writer->AddChunk(*chunk, &bad_chunk);
      }
      if (auto* r = std::get_if<storage::JournalRecord>(&**record))
        writer->AddJournal(*r, &bad_chunk);
    }
    writer->Finish(&bad_chunk);
  }
  absl::StatusOr<v1::Map> copy = Import(*client_, bad_chunk, "copy");
  EXPECT_EQ(copy.status().code(), absl::StatusCode::kDataLoss) << copy.status();
  EXPECT_THAT(copy.status().message(), HasSubstr("chunk rgb ("));
  EXPECT_EQ(client_->GetMap("maps/copy").status().code(), absl::StatusCode::kNotFound);
  // The server is well, and nothing of the failed imports is left in its store: the same
  // id imports fine now, and after a restart only the two maps exist.
  EXPECT_TRUE(server_.Running());
  ASSERT_TRUE(Import(*client_, file, "copy").ok());
  ASSERT_TRUE(server_.CrashAndRestart().ok());
  client_ = client::MapClient::Connect(server_.address());
  EXPECT_EQ(client_->ListAllMaps()->size(), 2u);
}

TEST_F(ExportImportTest, ACancelledImportLeavesNothing) {
  MakeMap(*client_, "src");
  const std::string file = Export(*client_, "maps/src", true);
  size_t at = 0;
  absl::StatusOr<v1::Map> cut = client_->ImportMap("copy", [&]() -> absl::StatusOr<std::string> {
    if (at > file.size() / 2) return absl::UnavailableError("disk went away");
    std::string piece = file.substr(at, 100000);
    at += piece.size();
    return piece;
  });
  EXPECT_EQ(cut.status().code(), absl::StatusCode::kUnavailable);
  // The server ends the import when it sees the cancellation; the id is then free again.
  absl::StatusOr<v1::Map> again;
  for (int i = 0; i < 100; ++i) {
    again = Import(*client_, file, "copy");
    if (again.status().code() != absl::StatusCode::kAlreadyExists) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  ASSERT_TRUE(again.ok()) << again.status();
  EXPECT_EQ(again->stats().frames(), 6u);
  EXPECT_TRUE(server_.Running());
}

TEST_F(ExportImportTest, ANewerFormatVersionIsRefused) {
  MakeMap(*client_, "src");
  std::string file = Export(*client_, "maps/src", false);
  file[4] = 2;  // format version 2, little-endian
  absl::StatusOr<v1::Map> copy = Import(*client_, file, "copy");
  EXPECT_EQ(copy.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_EQ(copy.status().message(),
            "export file format version 2 is newer than this server's 1; upgrade skimapd");
  EXPECT_EQ(client_->GetMap("maps/copy").status().code(), absl::StatusCode::kNotFound);
}

TEST_F(ExportImportTest, ATakenOrInvalidIdIsRefused) {
  MakeMap(*client_, "src");
  const std::string file = Export(*client_, "maps/src", true);
  const VoxelSet before = Voxels(*client_, "maps/src");
  absl::StatusOr<v1::Map> same = Import(*client_, file, "");  // the file's id: src
  EXPECT_EQ(same.status().code(), absl::StatusCode::kAlreadyExists);
  EXPECT_THAT(same.status().message(), HasSubstr("maps/src"));
  EXPECT_EQ(Voxels(*client_, "maps/src"), before);  // untouched
  absl::StatusOr<v1::Map> bad = Import(*client_, file, "Not An Id");
  EXPECT_EQ(bad.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(bad.status().message(), HasSubstr("map_id"));
  EXPECT_EQ(client_->ListAllMaps()->size(), 1u);
  // Exporting a map that does not exist.
  v1::ExportMapRequest request;
  request.set_name("maps/nope");
  EXPECT_EQ(client_->ExportMap(request, [](std::string_view) { return absl::OkStatus(); }).code(),
            absl::StatusCode::kNotFound);
}

TEST_F(ExportImportTest, ExportsWhileFramesArriveImportWhole) {
  SkimapdProcess busy(SKIMAPD_PATH, {"--worker_threads=1", "--snapshot_interval_s=1"});
  ASSERT_TRUE(busy.Start().ok());
  auto client = client::MapClient::Connect(busy.address());
  v1::CreateMapRequest create;
  create.set_map_id("live");
  ASSERT_TRUE(client->CreateMap(create).ok());
  std::atomic<bool> stop{false};
  std::atomic<int> sent{0};
  std::thread writer([&] {
    for (int i = 0; i < 500 && !stop; ++i) {
      EXPECT_TRUE(client->IntegrateFrame(MakeFrame("maps/live", i, View(i % 8))).ok());
      sent = i + 1;
    }
  });
  while (sent < 5) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  uint64_t frames = 0;
  for (int round = 0; round < 4; ++round) {
    const std::string file = Export(*client, "maps/live", round % 2 == 0);
    absl::StatusOr<v1::Map> copy = Import(*client, file, absl::StrCat("copy", round));
    ASSERT_TRUE(copy.ok()) << copy.status();
    EXPECT_GE(copy->stats().frames(), frames);  // each export has at least the earlier frames
    frames = copy->stats().frames();
    EXPECT_GT(copy->stats().voxels(), 0u);
  }
  EXPECT_LT(frames, 500u);  // the exports ran while frames arrived
  stop = true;
  writer.join();
}

TEST_F(ExportImportTest, TheCliExportsAndImportsFiles) {
  MakeMap(*client_, "src");
  const std::string file = dir_ + "/src.skmx", log = dir_ + "/cli.log";
  const std::string cli = absl::StrCat(SKIMAP_CLI_PATH, " --server=", server_.address(), " ");
  ASSERT_EQ(std::system((cli + "export --map src -o " + file + " --with-journal > " + log).c_str()),
            0);
  EXPECT_TRUE(fs::exists(file));
  EXPECT_FALSE(fs::exists(file + ".part"));
  ASSERT_EQ(std::system((cli + "import " + file + " --as clicopy >> " + log).c_str()), 0);
  EXPECT_EQ(Voxels(*client_, "maps/clicopy"), Voxels(*client_, "maps/src"));
  EXPECT_TRUE(client_->UpdatePoses(Moved("maps/clicopy", {3})).ok());  // journal included
  // Failures: exit code 1 and the server's message; no file is left by a failed export.
  const std::string bad = dir_ + "/bad.skmx";
  std::ifstream in(file, std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::ofstream(bad, std::ios::binary) << bytes.substr(0, bytes.size() - 7);
  EXPECT_NE(std::system((cli + "import " + bad + " --as other 2> " + log).c_str()), 0);
  std::ifstream err(log);
  std::stringstream text;
  text << err.rdbuf();
  EXPECT_THAT(text.str(), HasSubstr("DATA_LOSS"));
  EXPECT_THAT(text.str(), HasSubstr("truncated"));
  EXPECT_NE(std::system((cli + "export --map nope -o " + dir_ + "/nope.skmx 2> " + log).c_str()),
            0);
  EXPECT_FALSE(fs::exists(dir_ + "/nope.skmx"));
  EXPECT_FALSE(fs::exists(dir_ + "/nope.skmx.part"));
}

TEST(ExportImportInProcessTest, AServerWithoutADataDirAnswersFailedPrecondition) {
  server::Server::Options options;
  options.grpc.address = "127.0.0.1:0";
  options.maps.worker_threads = 1;
  auto server = server::Server::Start(options);
  ASSERT_TRUE(server.ok()) << server.status();
  auto client = client::MapClient::Connect(absl::StrCat("127.0.0.1:", (*server)->grpc_port()));
  v1::CreateMapRequest create;
  create.set_map_id("m");
  ASSERT_TRUE(client->CreateMap(create).ok());
  v1::ExportMapRequest request;
  request.set_name("maps/m");
  const absl::Status exported =
      client->ExportMap(request, [](std::string_view) { return absl::OkStatus(); });
  EXPECT_EQ(exported.code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(exported.message(), HasSubstr("--data_dir"));
  EXPECT_EQ(Import(*client, "SKEX....", "n").status().code(),
            absl::StatusCode::kFailedPrecondition);
}

TEST(ExportImportInProcessTest, AnImportCutShortByACrashIsRemovedAtStart) {
  const std::string dir =
      (fs::temp_directory_path() / absl::StrCat("skimap_half_import_", getpid())).string();
  fs::create_directories(dir);
  const std::string path = dir + "/maps.sqlite";
  {
    auto store = storage::SqliteMapStore::Open(path);
    ASSERT_TRUE(store.ok());
    ASSERT_TRUE((*store)->CreateMap("whole", "").ok());
    ASSERT_TRUE((*store)->BeginImport("half", "", 3).ok());
    storage::Chunk chunk;
    chunk.key.volume = "rgb";
    chunk.bytes = "half a map";
    ASSERT_TRUE((*store)->WriteSnapshot("half", 0, {chunk}, {}).ok());
  }
  {
    server::Server::Options options;
    options.grpc.address = "127.0.0.1:0";
    options.maps.worker_threads = 1;
    options.maps_db_path = path;
    auto server = server::Server::Start(options);
    ASSERT_TRUE(server.ok()) << server.status();
    auto client = client::MapClient::Connect(absl::StrCat("127.0.0.1:", (*server)->grpc_port()));
    auto maps = client->ListAllMaps();
    ASSERT_TRUE(maps.ok());
    ASSERT_EQ(maps->size(), 1u);
    EXPECT_EQ((*maps)[0].name(), "maps/whole");
    v1::CreateMapRequest create;
    create.set_map_id("half");  // the id is free again, on disk too
    EXPECT_TRUE(client->CreateMap(create).ok());
  }
  fs::remove_all(dir);
}

TEST(ExportImportInProcessTest, AMapBeingExportedIsNotEvicted) {
  const std::string dir =
      (fs::temp_directory_path() / absl::StrCat("skimap_export_evict_", getpid())).string();
  fs::create_directories(dir);
  {
    auto store = storage::SqliteMapStore::Open(dir + "/maps.sqlite");
    ASSERT_TRUE(store.ok());
    server::MapService::Options options;
    options.worker_threads = 1;
    options.store = store->get();
    options.memory_budget_bytes = 1;  // every map but the most recent one goes
    server::MapService service(options);
    for (const char* id : {"a", "b"}) {
      v1::CreateMapRequest create;
      create.set_map_id(id);
      ASSERT_TRUE(service.CreateMap(create).ok());
      std::promise<absl::Status> done;
      service.IntegrateFrame(
          std::make_shared<v1::Frame>(MakeFrame(absl::StrCat("maps/", id), 1, DefaultView())),
          [&](absl::StatusOr<v1::FrameAck> ack) { done.set_value(ack.status()); });
      ASSERT_TRUE(done.get_future().get().ok());
    }
    auto loaded = [&](const std::string& name) {
      const absl::StatusOr<v1::ListMapsResponse> maps = service.ListMaps({});
      for (const v1::Map& m : maps->maps()) {
        if (m.name() == name) return m.stats().loaded();
      }
      return false;
    };
    v1::ExportMapRequest request;
    request.set_name("maps/a");
    auto exporter = server::MapTransfer(&service).Export(request);
    ASSERT_TRUE(exporter.ok()) << exporter.status();
    v1::GetMapRequest get;
    get.set_name("maps/b");
    ASSERT_TRUE(service.GetMap(get).ok());  // b is the most recent; a would go
    service.SnapshotAll();
    EXPECT_TRUE(loaded("maps/a"));
    std::string file;
    for (;;) {
      auto piece = (*exporter)->Next();
      ASSERT_TRUE(piece.ok()) << piece.status();
      if (!piece->has_value()) break;
      file += **piece;
    }
    exporter->reset();
    service.SnapshotAll();
    EXPECT_FALSE(loaded("maps/a"));
    server::ExportReader reader;
    reader.Feed(file);
    EXPECT_TRUE(reader.Finish().ok());
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace skimap::testing
