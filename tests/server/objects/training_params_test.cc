// Training parameters through the API and the store: zoom_out applied, compared between a
// database's objects, written and read back; databases from before it read as 1.
#include <gtest/gtest.h>

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

}  // namespace
}  // namespace skimap::server
