// Bad input to the object service: each case gets its status code and a message that names
// the offending field.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tests/server/objects/object_service_fixture.h"

namespace skimap::testing {
namespace {

using objects::testing::TempDir;
using ::testing::HasSubstr;

class ObjectServiceErrorsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    server_ = StartServer(TempDir());
    ASSERT_NE(server_, nullptr);
    client_ = Connect(*server_);
    views_ = MiniViews(1, 4);
    ASSERT_FALSE(views_.empty());
  }
  // Trains object 9 from one view changed by `edit`; the call's status.
  absl::Status TrainOne(const std::function<void(v1::TrainingFrame*)>& edit,
                        const std::string& detector = "") {
    std::vector<v1::TrainingFrame> one = {views_[0]};
    edit(&one[0]);
    return Train(*client_, 9, one, detector).status();
  }

  std::unique_ptr<server::Server> server_;
  std::unique_ptr<client::ObjectClient> client_;
  std::vector<v1::TrainingFrame> views_;
};

TEST_F(ObjectServiceErrorsTest, MissingDepthIsInvalidArgumentNamingDepth) {
  absl::Status s = TrainOne([](v1::TrainingFrame* f) { f->clear_depth(); });
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(s.message(), HasSubstr("frames[0].depth"));
}

TEST_F(ObjectServiceErrorsTest, EmptyMaskIsInvalidArgumentNamingMask) {
  absl::Status s = TrainOne([](v1::TrainingFrame* f) {
    f->set_mask_encoding(v1::MASK_ENCODING_RAW_U8);
    f->set_mask(std::string(f->intrinsics().width() * f->intrinsics().height(), '\0'));
  });
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(s.message(), HasSubstr("frames[0].mask: empty"));
}

TEST_F(ObjectServiceErrorsTest, MissingPoseAndBadIntrinsicsNameTheirFields) {
  absl::Status pose = TrainOne([](v1::TrainingFrame* f) { f->clear_object_pose(); });
  EXPECT_EQ(pose.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(pose.message(), HasSubstr("object_pose"));
  absl::Status fx = TrainOne([](v1::TrainingFrame* f) { f->mutable_intrinsics()->set_fx(-1); });
  EXPECT_EQ(fx.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(fx.message(), HasSubstr("intrinsics.fx"));
}

TEST_F(ObjectServiceErrorsTest, UnknownDetectorIsInvalidArgumentNamingDetector) {
  absl::Status s = TrainOne([](v1::TrainingFrame*) {}, "SURF");
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(s.message(), HasSubstr("params.detector"));
}

TEST_F(ObjectServiceErrorsTest, BadObjectIdsAndNames) {
  absl::StatusOr<v1::Object> zero = Train(*client_, 0, views_);
  EXPECT_EQ(zero.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(zero.status().message(), HasSubstr("obj_id"));
  EXPECT_EQ(client_->GetObject("objects/77").status().code(), absl::StatusCode::kNotFound);
  EXPECT_EQ(client_->DeleteObject("objects/77").code(), absl::StatusCode::kNotFound);
  absl::Status bad = client_->GetObject("maps/x").status();
  EXPECT_EQ(bad.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(bad.message(), HasSubstr("name"));
  EXPECT_EQ(client_->GetOperation("operations/999").status().code(), absl::StatusCode::kNotFound);
  v1::ListObjectsRequest page;
  page.set_page_token("garbage");
  EXPECT_THAT(client_->ListObjects(page).status().message(), HasSubstr("page_token"));
}

TEST_F(ObjectServiceErrorsTest, StateErrorsAreFailedPreconditionOrAlreadyExists) {
  // No objects: nothing to build.
  EXPECT_EQ(client_->BuildClassifier({}).status().code(), absl::StatusCode::kFailedPrecondition);
  ASSERT_TRUE(Train(*client_, 5, views_).ok());
  EXPECT_EQ(Train(*client_, 5, views_).status().code(), absl::StatusCode::kAlreadyExists);
  // The database is ORB: another detector cannot join it.
  absl::StatusOr<v1::Object> sift = Train(*client_, 6, views_, "SIFT");
  EXPECT_EQ(sift.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(sift.status().message(), HasSubstr("params.detector"));
  // A bad classifier parameter is rejected before the build starts.
  v1::BuildClassifierRequest bad;
  bad.mutable_params()->set_trees(0);
  absl::Status trees = client_->BuildClassifier(bad).status();
  EXPECT_EQ(trees.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(trees.message(), HasSubstr("params.trees"));
  v1::BuildClassifierRequest fit;
  fit.mutable_params()->set_min_instance_fit(2);
  absl::Status unfit = client_->BuildClassifier(fit).status();
  EXPECT_EQ(unfit.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(unfit.message(), HasSubstr("params.min_instance_fit"));
  // Nothing was stored for the failed calls.
  absl::StatusOr<std::vector<v1::Object>> all = client_->ListAllObjects();
  ASSERT_TRUE(all.ok());
  EXPECT_EQ(all->size(), 1u);
}

}  // namespace
}  // namespace skimap::testing
