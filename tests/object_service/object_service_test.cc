// The object service end to end over gRPC: train two sim `mini` objects by streaming,
// list, get, build the classifier as a long-running operation, classify held-out views,
// restart on the same data dir, delete, rebuild from the reloaded training descriptors.
#include <gtest/gtest.h>

#include <cstdio>
#include <set>

#include "server/object_codec.h"
#include "tests/object_service/object_service_fixture.h"

namespace skimap::testing {
namespace {

using objects::testing::TempDir;
using server::ObjectName;

constexpr int kA = 1, kB = 2;

v1::BuildClassifierRequest SmallForest() {
  v1::BuildClassifierRequest r;
  r.mutable_params()->set_classes_per_object(100);
  r.mutable_params()->set_trees(24);
  r.mutable_params()->set_max_depth(24);
  return r;
}

// Held-out views of obj_id whose most voted object is obj_id, and how many views there are.
std::pair<int, int> ViewsRecognized(client::ObjectClient& c, int obj_id) {
  int right = 0, total = 0;
  for (const v1::ClassifyImageRequest& view : HeldOutImages(obj_id)) {
    absl::StatusOr<v1::ClassifyImageResponse> r = c.ClassifyImage(view);
    EXPECT_TRUE(r.ok()) << r.status();
    ++total;
    if (r.ok() && !r->objects().empty() && r->objects(0).object() == ObjectName(obj_id)) ++right;
  }
  return {right, total};
}

// Most held-out views of obj_id are recognized (measured: see docs/objects.md).
void ExpectRecognized(client::ObjectClient& c, int obj_id) {
  const auto [right, total] = ViewsRecognized(c, obj_id);
  EXPECT_GE(total, 4);
  EXPECT_GE(right * 3, total * 2) << right << " of " << total << " views of object " << obj_id;
  std::fprintf(stderr, "objects/%d: %d of %d held-out views recognized\n", obj_id, right, total);
}

TEST(ObjectServiceTest, TrainListGetBuildRestartDelete) {
  const std::string dir = TempDir();
  {
    std::unique_ptr<server::GrpcServer> s = StartServer(dir);
    ASSERT_NE(s, nullptr);
    std::unique_ptr<client::ObjectClient> c = Connect(*s);
    for (int id : {kA, kB}) {
      absl::StatusOr<v1::Object> o = Train(*c, id, MiniViews(id, 1));
      ASSERT_TRUE(o.ok()) << o.status();
      EXPECT_EQ(o->name(), absl::StrCat("objects/", id));
      EXPECT_GT(o->frames(), 0u);
      EXPECT_GT(o->voxels(), 10u);
      EXPECT_GT(o->centroids(), o->voxels() - 1);
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
    EXPECT_EQ(page->next_page_token(), "objects/1");

    absl::StatusOr<v1::Object> full = c->GetObject("objects/1", v1::OBJECT_VIEW_FULL);
    ASSERT_TRUE(full.ok()) << full.status();
    EXPECT_GT(full->rgb_voxels_size(), 100);
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
    EXPECT_EQ(op->classifier().classes(), 200u);
    ExpectRecognized(*c, kA);
    ExpectRecognized(*c, kB);
    absl::StatusOr<v1::Operation> again = c->GetOperation(op->name());
    ASSERT_TRUE(again.ok());
    EXPECT_TRUE(again->done());
  }
  {
    // Restart on the same data dir: objects and classifier are reloaded.
    std::unique_ptr<server::GrpcServer> s = StartServer(dir);
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
    ExpectRecognized(*c, kA);

    ASSERT_TRUE(c->DeleteObject("objects/1").ok());
    EXPECT_EQ(c->GetObject("objects/1").status().code(), absl::StatusCode::kNotFound);
    EXPECT_EQ(c->GetClassifier()->state(), v1::Classifier::NOT_BUILT);
  }
  {
    // After the delete and a restart: one object, rebuilt from its stored descriptors.
    std::unique_ptr<server::GrpcServer> s = StartServer(dir);
    ASSERT_NE(s, nullptr);
    std::unique_ptr<client::ObjectClient> c = Connect(*s);
    absl::StatusOr<std::vector<v1::Object>> all = c->ListAllObjects();
    ASSERT_TRUE(all.ok());
    ASSERT_EQ(all->size(), 1u);
    EXPECT_EQ((*all)[0].name(), "objects/2");
    absl::StatusOr<v1::Operation> op = c->BuildClassifier(SmallForest());
    ASSERT_TRUE(op.ok()) << op.status();
    op = c->WaitDone(op->name(), nullptr, absl::Milliseconds(100));
    ASSERT_TRUE(op.ok()) << op.status();
    EXPECT_EQ(op->classifier().objects_size(), 1);
    ExpectRecognized(*c, kB);
  }
}

TEST(ObjectServiceTest, TrainFromServerDatasetIsAnOperationWithProgress) {
  std::unique_ptr<server::GrpcServer> s = StartServer(TempDir());
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
  EXPECT_GE(answers, 1);
  EXPECT_EQ(op->object().name(), "objects/3");
  EXPECT_EQ(op->object().display_name(), "teabox");  // from objects.json
  EXPECT_GT(op->object().voxels(), 10u);
  // The same object again: ALREADY_EXISTS at once; a missing dataset: NOT_FOUND.
  EXPECT_EQ(c->TrainObjectFromDataset(r).status().code(), absl::StatusCode::kAlreadyExists);
  r.set_obj_id(4);
  r.set_dataset_path("/nonexistent/skimap-dataset");
  EXPECT_EQ(c->TrainObjectFromDataset(r).status().code(), absl::StatusCode::kNotFound);
}

}  // namespace
}  // namespace skimap::testing
