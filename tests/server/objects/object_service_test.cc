// The object service end to end over gRPC: train two sim `mini` objects by streaming,
// list, get, build the classifier as a long-running operation, classify held-out views,
// restart on the same data dir, delete, rebuild from the reloaded training descriptors.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <map>
#include <set>

#include "server/core/objects/object_codec.h"
#include "tests/server/objects/object_service_fixture.h"

namespace skimap::testing {
namespace {

using objects::testing::TempDir;
using server::ObjectName;

constexpr int kA = 1, kB = 2;

v1::BuildClassifierRequest SmallForest() {
  v1::BuildClassifierRequest r;
  r.mutable_params()->set_classes_per_object(300);
  r.mutable_params()->set_trees(24);
  r.mutable_params()->set_max_depth(24);
  return r;
}

// ClassifyImage over the held-out views of obj_id, summed.
struct ViewStats {
  int views = 0;
  int right_views = 0;       // views whose most voted object is `as`
  uint64_t features = 0;     // detected in the masks
  uint64_t verified = 0;     // with a verified prediction (a vote)
  uint64_t right_votes = 0;  // votes for `as`
  double VoteShare() const { return verified ? double(right_votes) / verified : 0; }
  double VerifiedRate() const { return features ? double(verified) / features : 0; }
};

ViewStats ClassifyViews(client::ObjectClient& c, int view_obj_id, int as) {
  ViewStats s;
  for (const v1::ClassifyImageRequest& view : HeldOutImages(view_obj_id)) {
    absl::StatusOr<v1::ClassifyImageResponse> r = c.ClassifyImage(view);
    EXPECT_TRUE(r.ok()) << r.status();
    ++s.views;
    if (!r.ok()) continue;
    s.features += r->features();
    s.verified += r->verified();
    for (const v1::ObjectVotes& v : r->objects()) {
      if (v.object() == ObjectName(as)) s.right_votes += v.votes();
    }
    if (!r->objects().empty() && r->objects(0).object() == ObjectName(as)) ++s.right_views;
  }
  std::fprintf(stderr,
               "[ measured ] views of objects/%d as objects/%d: %d/%d views, %llu of %llu votes "
               "(%.3f), %llu of %llu features verified (%.3f)\n",
               view_obj_id, as, s.right_views, s.views, (unsigned long long)s.right_votes,
               (unsigned long long)s.verified, s.VoteShare(), (unsigned long long)s.verified,
               (unsigned long long)s.features, s.VerifiedRate());
  return s;
}

// The held-out views of obj_id are recognized. With two objects in the classifier chance
// gives half the views and half the votes; the floors sit between chance and what was
// measured (see the call sites).
void ExpectRecognized(client::ObjectClient& c, int obj_id, double min_vote_share) {
  const ViewStats s = ClassifyViews(c, obj_id, obj_id);
  EXPECT_EQ(s.views, 6);
  // Measured 2026-11-24: 6/6 and 5/6 (cereal). A third fewer would be 4/6, which chance
  // reaches one time in three, so the floor is 5/6 (chance: 11 %); the vote share carries
  // the rest.
  EXPECT_GE(s.right_views, 5) << "objects/" << obj_id;
  EXPECT_GE(s.VoteShare(), min_vote_share) << "objects/" << obj_id;
}

TEST(ObjectServiceTest, TrainListGetBuildRestartDelete) {
  const std::string dir = TempDir();
  {
    std::unique_ptr<server::Server> s = StartServer(dir);
    ASSERT_NE(s, nullptr);
    std::unique_ptr<client::ObjectClient> c = Connect(*s);
    // Measured 2026-11-23 (18 training views each): object 1 127 voxels / 1216 centroids,
    // object 2 433 / 1952. Floors: two thirds of the voxels, and at least 3 centroids per
    // voxel (measured 9.6 and 4.5).
    const std::map<int, uint64_t> min_voxels = {{kA, 85}, {kB, 290}};
    for (int id : {kA, kB}) {
      absl::StatusOr<v1::Object> o = Train(*c, id, MiniViews(id, 1));
      ASSERT_TRUE(o.ok()) << o.status();
      EXPECT_EQ(o->name(), absl::StrCat("objects/", id));
      EXPECT_EQ(o->frames(), 18u);
      EXPECT_GE(o->voxels(), min_voxels.at(id));
      EXPECT_GE(o->centroids(), 3 * o->voxels());
      EXPECT_EQ(o->params().detector(), "ORB");
    }
    absl::StatusOr<std::vector<v1::Object>> all = c->ListAllObjects();
    ASSERT_TRUE(all.ok()) << all.status();
    ASSERT_EQ(all->size(), 2u);
    EXPECT_EQ((*all)[0].name(), "objects/1");
    EXPECT_EQ((*all)[1].name(), "objects/2");
    v1::ListObjectsRequest one_per_page;
    one_per_page.set_page_size(1);
    absl::StatusOr<v1::ListObjectsResponse> page = c->ListObjects(one_per_page);
    ASSERT_TRUE(page.ok());
    EXPECT_EQ(page->objects_size(), 1);
    ASSERT_FALSE(page->next_page_token().empty());  // opaque
    one_per_page.set_page_token(page->next_page_token());
    absl::StatusOr<v1::ListObjectsResponse> second = c->ListObjects(one_per_page);
    ASSERT_TRUE(second.ok()) << second.status();
    ASSERT_EQ(second->objects_size(), 1);
    EXPECT_EQ(second->objects(0).name(), "objects/2");
    one_per_page.set_page_token("objects/1");  // a bare name is not a token
    EXPECT_EQ(c->ListObjects(one_per_page).status().code(), absl::StatusCode::kInvalidArgument);

    absl::StatusOr<v1::Object> full = c->GetObject("objects/1", v1::OBJECT_VIEW_FULL);
    ASSERT_TRUE(full.ok()) << full.status();
    EXPECT_GE(full->rgb_voxels_size(), 90);  // measured 136 (2026-11-23); two thirds
    EXPECT_DOUBLE_EQ(full->rgb_resolution(), 0.01);
    EXPECT_FALSE(full->in_classifier());

    absl::StatusOr<v1::Classifier> none = c->GetClassifier();
    ASSERT_TRUE(none.ok());
    EXPECT_EQ(none->state(), v1::Classifier::NOT_BUILT);
    EXPECT_EQ(c->ClassifyImage(HeldOutImages(kA).at(0)).status().code(),
              absl::StatusCode::kFailedPrecondition);

    absl::StatusOr<v1::Operation> op = c->BuildClassifier(SmallForest());
    ASSERT_TRUE(op.ok()) << op.status();
    EXPECT_EQ(op->kind(), "BuildClassifier");
    std::set<std::string> stages;
    double last_fraction = 0;
    bool monotonic = true;
    op = c->WaitDone(
        op->name(),
        [&](const v1::Operation& p) {
          stages.insert(p.progress().stage());
          monotonic = monotonic && p.progress().fraction() >= last_fraction;
          last_fraction = p.progress().fraction();
        },
        absl::Milliseconds(50));
    ASSERT_TRUE(op.ok()) << op.status();
    EXPECT_TRUE(op->done());
    EXPECT_EQ(op->code(), 0);
    EXPECT_TRUE(monotonic);
    EXPECT_DOUBLE_EQ(op->progress().fraction(), 1.0);
    EXPECT_TRUE(stages.count("forest") || stages.count("saving"))
        << "stages seen: " << stages.size();
    EXPECT_EQ(op->classifier().state(), v1::Classifier::READY);
    EXPECT_EQ(op->classifier().objects_size(), 2);
    EXPECT_EQ(op->classifier().classes(), 600u);
    // Vote shares measured 2026-11-24 (deterministic for the seed; 24 trees x 24, 300
    // classes): object 1 0.816, object 2 0.598 (the cereal box's large printed faces hold
    // more voxels than its classes); 2026-11-28 with the default zoom-outs: 0.749 and 0.684.
    // Floors keep two thirds of the margin over chance (0.5) of the 2026-11-24 figures:
    // 0.5 + 2/3 x (measured - 0.5).
    ExpectRecognized(*c, kA, 0.71);
    ExpectRecognized(*c, kB, 0.56);
    absl::StatusOr<v1::Operation> again = c->GetOperation(op->name());
    ASSERT_TRUE(again.ok());
    EXPECT_TRUE(again->done());
  }
  {
    // Restart on the same data dir: objects and classifier are reloaded.
    std::unique_ptr<server::Server> s = StartServer(dir);
    ASSERT_NE(s, nullptr);
    std::unique_ptr<client::ObjectClient> c = Connect(*s);
    absl::StatusOr<std::vector<v1::Object>> all = c->ListAllObjects();
    ASSERT_TRUE(all.ok());
    ASSERT_EQ(all->size(), 2u);
    EXPECT_TRUE((*all)[0].in_classifier());
    absl::StatusOr<v1::Classifier> ready = c->GetClassifier();
    ASSERT_TRUE(ready.ok());
    EXPECT_EQ(ready->state(), v1::Classifier::READY);
    EXPECT_EQ(ready->params().trees(), 24u);
    ExpectRecognized(*c, kA, 0.71);  // the same classifier, reloaded: measured 0.749

    ASSERT_TRUE(c->DeleteObject("objects/1").ok());
    EXPECT_EQ(c->GetObject("objects/1").status().code(), absl::StatusCode::kNotFound);
    EXPECT_EQ(c->GetClassifier()->state(), v1::Classifier::NOT_BUILT);
  }
  {
    // After the delete and a restart: one object, rebuilt from its stored descriptors.
    std::unique_ptr<server::Server> s = StartServer(dir);
    ASSERT_NE(s, nullptr);
    std::unique_ptr<client::ObjectClient> c = Connect(*s);
    absl::StatusOr<std::vector<v1::Object>> all = c->ListAllObjects();
    ASSERT_TRUE(all.ok());
    ASSERT_EQ(all->size(), 1u);
    EXPECT_EQ((*all)[0].name(), "objects/2");
    v1::BuildClassifierRequest strict = SmallForest();
    strict.mutable_params()->set_verify_threshold(50);  // bits (default 0.3 x 256 = 77)
    absl::StatusOr<v1::Operation> op = c->BuildClassifier(strict);
    ASSERT_TRUE(op.ok()) << op.status();
    op = c->WaitDone(op->name(), nullptr, absl::Milliseconds(100));
    ASSERT_TRUE(op.ok()) << op.status();
    EXPECT_EQ(op->classifier().objects_size(), 1);
    // One object: every vote is for it, so the vote share says nothing. Verification does:
    // features of object 1 (deleted) must mostly fail it, features of object 2 pass.
    const ViewStats own = ClassifyViews(*c, kB, kB);
    const ViewStats foreign = ClassifyViews(*c, kA, kB);
    // Measured 2026-11-28 with a 50-bit threshold and the default zoom-outs (to 4): 0.096 of
    // object 2's features verified, 0.049 of object 1's: 1.96 x (without zoom-outs, 2026-11-24:
    // 0.092 and 0.021, 4.4 x; the shrunk views' blurrier descriptors sit between objects,
    // docs/objects.md "Zoom-outs"). (With ORB's default of 77 bits both are 0.62: for these
    // printed textures the default verifies almost anything; recognition's voting and its
    // check against the map carry the rest, docs/recognition.md.) Without verification both
    // would be 1. Floor: two thirds of the measured ratio.
    EXPECT_EQ(own.views, 6);
    EXPECT_EQ(own.right_views, 6);
    EXPECT_GE(own.VerifiedRate(), 1.3 * foreign.VerifiedRate());
    EXPECT_GT(own.VerifiedRate(), 0);
  }
}

TEST(ObjectServiceTest, TrainFromServerDatasetIsAnOperationWithProgress) {
  std::unique_ptr<server::Server> s = StartServer(TempDir());
  ASSERT_NE(s, nullptr);
  std::unique_ptr<client::ObjectClient> c = Connect(*s);
  v1::TrainObjectFromDatasetRequest r;
  r.set_dataset_path(objects::testing::MiniDataset());
  r.set_obj_id(3);
  r.set_frame_stride(3);
  absl::StatusOr<v1::Operation> op = c->TrainObjectFromDataset(r);
  ASSERT_TRUE(op.ok()) << op.status();
  EXPECT_EQ(op->kind(), "TrainObjectFromDataset");
  int answers = 0;
  op = c->WaitDone(
      op->name(), [&](const v1::Operation&) { ++answers; }, absl::Milliseconds(50));
  ASSERT_TRUE(op.ok()) << op.status();
  EXPECT_GE(answers, 1);  // timing-dependent (measured 5): at least the final answer
  EXPECT_EQ(op->object().name(), "objects/3");
  EXPECT_EQ(op->object().display_name(), "teabox");  // from objects.json
  EXPECT_GE(op->object().voxels(), 250u);            // measured 378 (2026-11-23); two thirds
  // The same object again: ALREADY_EXISTS at once; a missing dataset: NOT_FOUND.
  EXPECT_EQ(c->TrainObjectFromDataset(r).status().code(), absl::StatusCode::kAlreadyExists);
  r.set_obj_id(4);
  r.set_dataset_path("no-such-dataset");  // relative to the dataset root
  EXPECT_EQ(c->TrainObjectFromDataset(r).status().code(), absl::StatusCode::kNotFound);
}

TEST(ObjectServiceTest, DatasetPathsStayUnderTheDatasetRootAndAreNeverEchoedOutsideIt) {
  std::unique_ptr<server::Server> s = StartServer(TempDir());
  ASSERT_NE(s, nullptr);
  std::unique_ptr<client::ObjectClient> c = Connect(*s);
  const std::string root = SKIMAP_OBJECTS_TEST_DATA_DIR;
  std::filesystem::create_directories(root);
  // A symbolic link inside the root that points out of it.
  const std::string link = root + "/escape";
  std::filesystem::remove(link);
  std::filesystem::create_directory_symlink("/etc", link);
  v1::TrainObjectFromDatasetRequest r;
  r.set_obj_id(5);
  for (const std::string& outside : {std::string("/etc"), std::string("/nonexistent/secret-dir"),
                                     std::string("../../../../../../etc"), root + "/../x",
                                     root + "2", std::string("escape/ssl")}) {
    SCOPED_TRACE(outside);
    r.set_dataset_path(outside);
    const absl::Status status = c->TrainObjectFromDataset(r).status();
    EXPECT_EQ(status.code(), absl::StatusCode::kPermissionDenied) << status;
    EXPECT_THAT(status.message(), ::testing::Not(::testing::HasSubstr("etc")));
    EXPECT_THAT(status.message(), ::testing::Not(::testing::HasSubstr("secret")));
  }
  std::filesystem::remove(link);
  // A server without a root reads no dataset at all.
  const std::string dir = TempDir();
  server::Server::Options o;
  o.grpc.address = "127.0.0.1:0";
  o.objects.db_path = dir + "/objects.sqlite";
  absl::StatusOr<std::unique_ptr<server::Server>> closed = server::Server::Start(o);
  ASSERT_TRUE(closed.ok());
  r.set_dataset_path(objects::testing::MiniDataset());
  EXPECT_EQ(client::ObjectClient::Connect(absl::StrCat("127.0.0.1:", (*closed)->grpc_port()))
                ->TrainObjectFromDataset(r)
                .status()
                .code(),
            absl::StatusCode::kPermissionDenied);
}

}  // namespace
}  // namespace skimap::testing
