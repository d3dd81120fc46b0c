// Training parameters through the API and the store: the defaults a new user gets (SIFT,
// 300 classes); zoom_out applied, compared between a database's objects, written and read
// back (databases from before it read as 1); the instance thresholds each detector brings,
// stored with the classifier.
#include <gtest/gtest.h>

#include <cmath>

#include "server/core/objects/object_codec.h"
#include "server/core/objects/object_database_io.h"

namespace skimap::server {
namespace {

TEST(TrainingParamsTest, ZoomOutIsAppliedValidatedAndSharedByTheDatabase) {
  objects::ObjectDatabaseParams defaults;
  EXPECT_EQ(defaults.zoom_out, 4);
  v1::TrainingParams api;
  api.set_zoom_out(2);
  absl::StatusOr<objects::ObjectDatabaseParams> p = ApplyTrainingParams(api, defaults);
  ASSERT_TRUE(p.ok()) << p.status();
  EXPECT_EQ(p->zoom_out, 2);
  EXPECT_EQ(ToApiTrainingParams(*p).zoom_out(), 2);

  api.set_zoom_out(0.5);
  absl::Status bad = ApplyTrainingParams(api, defaults).status();
  EXPECT_EQ(bad.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(bad.message().find("params.zoom_out"), std::string::npos) << bad;

  absl::StatusOr<objects::ObjectDatabaseParams> db =
      ApplyTrainingParams(v1::TrainingParams(), defaults);  // resolved defaults: zoom 4
  ASSERT_TRUE(db.ok()) << db.status();
  EXPECT_TRUE(CheckSameTraining(*db, *db).ok());
  const absl::Status differs = CheckSameTraining(*p, *db);
  EXPECT_EQ(differs.code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_NE(differs.message().find("zoom_out"), std::string::npos) << differs;
}

TEST(TrainingParamsTest, ZoomOutRoundTripsAndOldDatabasesReadAsOne) {
  objects::ObjectDatabaseParams p;
  p.zoom_out = 2.8284271247461903;
  std::map<std::string, std::string> text = objects::ParamsToText(p);
  absl::StatusOr<objects::ObjectDatabaseParams> back = objects::ParamsFromText(text);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(back->zoom_out, p.zoom_out);
  text.erase("zoom_out");  // a database written before zoom-outs
  back = objects::ParamsFromText(text);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(back->zoom_out, 1);
  text["zoom_out"] = "lots";
  EXPECT_EQ(objects::ParamsFromText(text).status().code(), absl::StatusCode::kInvalidArgument);
}

TEST(TrainingParamsTest, ANewDatabaseIsSiftWith300ClassesAndSiftsInstanceThresholds) {
  // A fresh server's base: the struct's defaults, resolved.
  absl::StatusOr<objects::ObjectDatabaseParams> base =
      objects::ResolveParams(objects::ObjectDatabaseParams());
  ASSERT_TRUE(base.ok()) << base.status();
  absl::StatusOr<objects::ObjectDatabaseParams> p =
      ApplyTrainingParams(v1::TrainingParams(), *base);  // the client sets nothing
  ASSERT_TRUE(p.ok()) << p.status();
  EXPECT_EQ(p->features.detector, "SIFT");
  EXPECT_EQ(p->classes_per_object, 300);
  EXPECT_EQ(p->instances, (objects::InstanceThresholds{52, 0.3, 0.1}));
  const v1::ClassifierParams api = ToApiClassifierParams(*p);
  EXPECT_EQ(api.classes_per_object(), 300u);
  EXPECT_EQ(api.min_instance_score(), 52);
  EXPECT_EQ(api.min_instance_fit(), 0.3);
  EXPECT_EQ(api.max_view_conflict(), 0.1);
}

TEST(TrainingParamsTest, EachDetectorBringsItsOwnInstanceThresholds) {
  absl::StatusOr<objects::ObjectDatabaseParams> base =
      objects::ResolveParams(objects::ObjectDatabaseParams());
  ASSERT_TRUE(base.ok()) << base.status();
  v1::TrainingParams orb;
  orb.set_detector("orb");
  absl::StatusOr<objects::ObjectDatabaseParams> p = ApplyTrainingParams(orb, *base);
  ASSERT_TRUE(p.ok()) << p.status();
  EXPECT_EQ(p->features.detector, "ORB");
  EXPECT_EQ(p->instances, (objects::InstanceThresholds{112, 0.4, 0.02}));

  // Set on the classifier, kept, validated with the field named.
  v1::ClassifierParams set;
  set.set_min_instance_score(90);
  absl::StatusOr<objects::ObjectDatabaseParams> c = ApplyClassifierParams(set, *p);
  ASSERT_TRUE(c.ok()) << c.status();
  EXPECT_EQ(c->instances, (objects::InstanceThresholds{90, 0.4, 0.02}));
  set.set_min_instance_fit(1.5);
  absl::Status bad = ApplyClassifierParams(set, *p).status();
  EXPECT_EQ(bad.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(bad.message().find("params.min_instance_fit"), std::string::npos) << bad;
  set.clear_min_instance_fit();
  set.set_max_view_conflict(std::nan(""));
  bad = ApplyClassifierParams(set, *p).status();
  EXPECT_NE(bad.message().find("params.max_view_conflict"), std::string::npos) << bad;

  // Stored and read back; a database from before they were stored gets its detector's.
  std::map<std::string, std::string> text = objects::ParamsToText(*c);
  absl::StatusOr<objects::ObjectDatabaseParams> back = objects::ParamsFromText(text);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(back->instances, c->instances);
  for (const char* key : {"min_instance_score", "min_instance_fit", "max_view_conflict"}) {
    text.erase(key);
  }
  back = objects::ParamsFromText(text);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(back->instances, (objects::InstanceThresholds{112, 0.4, 0.02}));
  // ... as read, resolved: what ObjectDatabase::Create asks of stored parameters.
  absl::StatusOr<objects::ObjectDatabaseParams> resolved = objects::ResolveParams(*back);
  ASSERT_TRUE(resolved.ok()) << resolved.status();
  EXPECT_EQ(*resolved, *back);
  // A corrupt stored threshold is refused, naming it, never used.
  for (const char* bad : {"nan", "1.5"}) {
    text["min_instance_fit"] = bad;
    absl::StatusOr<objects::ObjectDatabaseParams> read = objects::ParamsFromText(text);
    if (read.ok()) read = objects::ResolveParams(*read);
    EXPECT_EQ(read.status().code(), absl::StatusCode::kInvalidArgument) << bad;
  }
}

}  // namespace
}  // namespace skimap::server
