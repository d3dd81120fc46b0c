// A classifier build whose objects change while it waits or runs ends ABORTED and installs
// nothing (docs/api.md, "Consistency"; server/core/objects/object_registry.h), and the service is
// left able to build again. Deterministic: operations run one at a time on the job worker, so a
// TrainObjectFromDataset submitted before a BuildClassifier adds its object after the
// build took its input (BeginBuild) and before the build finishes.
#include <gtest/gtest.h>

#include "tests/server/objects/object_service_fixture.h"

namespace skimap::testing {
namespace {

using objects::testing::TempDir;

constexpr int kObjA = 1, kObjB = 2, kObjC = 3;

v1::BuildClassifierRequest QuickForest() {
  v1::BuildClassifierRequest r;
  r.mutable_params()->set_classes_per_object(100);
  r.mutable_params()->set_trees(8);
  r.mutable_params()->set_max_depth(16);
  return r;
}

TEST(ObjectServiceAbortTest, BuildOvertakenByATrainingEndsAbortedAndInstallsNothing) {
  const std::string dir = TempDir();
  {
    std::unique_ptr<server::Server> s = StartServer(dir);
    ASSERT_NE(s, nullptr);
    std::unique_ptr<client::ObjectClient> c = Connect(*s);
    for (int id : {kObjA, kObjB}) ASSERT_TRUE(Train(*c, id, MiniViews(id, 2)).ok());
    absl::StatusOr<v1::Operation> first = c->BuildClassifier(QuickForest());
    ASSERT_TRUE(first.ok()) << first.status();
    ASSERT_TRUE(c->WaitDone(first->name(), nullptr, absl::Milliseconds(20)).ok());
    ASSERT_EQ(c->GetClassifier()->state(), v1::Classifier::READY);

    // The job worker trains object 3 first; the build queued behind it took objects 1 and 2.
    v1::TrainObjectFromDatasetRequest train;
    train.set_dataset_path(objects::testing::MiniDataset());
    train.set_obj_id(kObjC);
    train.set_frame_stride(3);
    absl::StatusOr<v1::Operation> training = c->TrainObjectFromDataset(train);
    ASSERT_TRUE(training.ok()) << training.status();
    absl::StatusOr<v1::Operation> build = c->BuildClassifier(QuickForest());
    ASSERT_TRUE(build.ok()) << build.status();
    EXPECT_FALSE(build->done());
    // One build at a time: a second one is refused while this one is pending.
    EXPECT_EQ(c->BuildClassifier(QuickForest()).status().code(),
              absl::StatusCode::kFailedPrecondition);

    ASSERT_TRUE(c->WaitDone(training->name(), nullptr, absl::Milliseconds(20)).ok());
    absl::StatusOr<v1::Operation> done =
        c->WaitDone(build->name(), nullptr, absl::Milliseconds(20));
    EXPECT_EQ(done.status().code(), absl::StatusCode::kAborted) << done.status();
    absl::StatusOr<v1::Operation> op = c->GetOperation(build->name());
    ASSERT_TRUE(op.ok()) << op.status();
    EXPECT_TRUE(op->done());
    EXPECT_EQ(op->code(), static_cast<int>(absl::StatusCode::kAborted));
    EXPECT_NE(op->message().find("objects changed"), std::string::npos) << op->message();
    EXPECT_FALSE(op->has_classifier() && op->classifier().state() == v1::Classifier::READY);

    // Nothing was installed: neither the aborted forest (objects 1 and 2 only) nor the
    // previous one (training object 3 dropped it). Not BUILDING either: the build is over.
    absl::StatusOr<v1::Classifier> state = c->GetClassifier();
    ASSERT_TRUE(state.ok());
    EXPECT_EQ(state->state(), v1::Classifier::NOT_BUILT);
    EXPECT_EQ(state->objects_size(), 0);
    EXPECT_EQ(c->ClassifyImage(HeldOutImages(kObjA).at(0)).status().code(),
              absl::StatusCode::kFailedPrecondition);
    absl::StatusOr<std::vector<v1::Object>> all = c->ListAllObjects();
    ASSERT_TRUE(all.ok());
    ASSERT_EQ(all->size(), 3u);
    for (const v1::Object& o : *all) EXPECT_FALSE(o.in_classifier()) << o.name();
  }
  {
    // Nor was anything persisted: after a restart the classifier is still not built, and a
    // new build over all three objects starts, succeeds and serves.
    std::unique_ptr<server::Server> s = StartServer(dir);
    ASSERT_NE(s, nullptr);
    std::unique_ptr<client::ObjectClient> c = Connect(*s);
    EXPECT_EQ(c->GetClassifier()->state(), v1::Classifier::NOT_BUILT);
    absl::StatusOr<v1::Operation> build = c->BuildClassifier(QuickForest());
    ASSERT_TRUE(build.ok()) << build.status();
    absl::StatusOr<v1::Operation> done =
        c->WaitDone(build->name(), nullptr, absl::Milliseconds(20));
    ASSERT_TRUE(done.ok()) << done.status();
    EXPECT_EQ(done->classifier().state(), v1::Classifier::READY);
    EXPECT_EQ(done->classifier().objects_size(), 3);
    EXPECT_EQ(done->classifier().classes(), 300u);
    absl::StatusOr<v1::ClassifyImageResponse> r = c->ClassifyImage(HeldOutImages(kObjC).at(0));
    ASSERT_TRUE(r.ok()) << r.status();
    ASSERT_GT(r->objects_size(), 0);
    EXPECT_EQ(r->objects(0).object(), "objects/3");
  }
}

}  // namespace
}  // namespace skimap::testing
