// The offline pipeline on the sim `mini` objects (generated at test time): held-out views
// are classified to the right object, classes map back to the right object and voxel,
// the Fig. 4 memory behaviour, the RGB volume, and SQLite persistence.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <opencv2/imgproc.hpp>

#include "absl/strings/str_format.h"
#include "dataset/reader.h"
#include "perception/objects/evaluation.h"
#include "perception/objects/training.h"
#include "server/core/objects/object_database_io.h"
#include "skimap/serialization.h"
#include "tests/perception/objects/sim_data.h"

namespace skimap::objects {
namespace {
namespace fs = std::filesystem;
using testing::HeldOutView;
using testing::MiniDataset;
using testing::TrainView;

ObjectDatabaseParams Params(const std::string& detector) {
  ObjectDatabaseParams p;
  p.features.detector = detector;
  p.classes_per_object = 300;
  p.forest.trees = 24;
  p.forest.max_depth = 24;
  return p;
}

// One trained ORB database per test process.
const ObjectDatabase& OrbDatabase() {
  static const ObjectDatabase* db = [] {
    absl::StatusOr<ObjectDatabase> d =
        TrainObjectDatabase(MiniDataset(), Params("ORB"), {.use_frame = TrainView});
    EXPECT_TRUE(d.ok()) << d.status();
    return d.ok() ? new ObjectDatabase(*std::move(d)) : new ObjectDatabase();
  }();
  return *db;
}

// A floor that keeps two thirds of a measured rate's margin over chance: a regression that
// loses a third of what the pipeline adds to guessing fails (and the floor is never below
// 0.67 x measured).
double FloorAboveChance(double measured, double chance) {
  return chance + (measured - chance) * 2 / 3;
}

// What HeldOutViewsAreClassifiedToTheRightObject measured on 2026-11-24 (deterministic for
// the seeds: the same values on every run and thread count), with 300 classes per object.
// Per object: boxgreen (1), cereal (2), teabox (3), each a printed box (every face a
// different part of its photograph). The cereal box is the hardest: 19 x 28 cm faces hold
// more voxels than its classes cover, and ORB's verification is loose.
struct Measured {
  const char* detector;
  double top1, verified;      // all held-out features
  double object_verified[3];  // per object
  int object_views[3];        // held-out views (of 6) recognised per object
};
constexpr Measured kMeasured[] = {
    {"ORB", 0.478, 0.557, {0.645, 0.421, 0.689}, {6, 5, 6}},
    {"SIFT", 0.572, 0.907, {0.975, 0.819, 0.967}, {6, 6, 6}},
};

TEST(ObjectPipelineTest, HeldOutViewsAreClassifiedToTheRightObject) {
  constexpr double kChance = 1.0 / 3;  // 3 objects
  for (const Measured& m : kMeasured) {
    const char* detector = m.detector;
    absl::StatusOr<ObjectDatabase> db =
        std::string(detector) == "ORB"
            ? absl::StatusOr<ObjectDatabase>(OrbDatabase())
            : TrainObjectDatabase(MiniDataset(), Params(detector), {.use_frame = TrainView});
    ASSERT_TRUE(db.ok()) << db.status();
    ASSERT_EQ(db->objects().size(), 3u);
    absl::StatusOr<std::vector<ObjectAccuracy>> acc =
        EvaluateViews(*db, MiniDataset(), {.use_frame = HeldOutView});
    ASSERT_TRUE(acc.ok()) << acc.status();
    const ObjectAccuracy total = Total(*acc);
    std::printf("[ measured ] %s: feature top-1 %.3f, verified precision %.3f, views %d/%d\n",
                detector, total.Top1Rate(), total.VerifiedPrecision(), total.views_correct,
                total.views);
    ASSERT_EQ(acc->size(), 3u);
    for (size_t i = 0; i < acc->size(); ++i) {
      const ObjectAccuracy& a = (*acc)[i];
      std::printf("[ measured ] %s object %d: views %d/%d, verified precision %.3f\n", detector,
                  a.obj_id, a.views_correct, a.views, a.VerifiedPrecision());
      EXPECT_EQ(a.views, 6) << detector << " object " << a.obj_id;
      EXPECT_GT(a.features, 0);
      // Per object, held-out views are recognised: one view fewer than measured at most
      // (chance, 1/3 a view, reaches 4/6 10 % of the time and 5/6 2 %).
      EXPECT_GE(a.views_correct, m.object_views[i] - 1) << detector << " object " << a.obj_id;
      EXPECT_GE(a.VerifiedPrecision(), FloorAboveChance(m.object_verified[i], kChance))
          << detector << " object " << a.obj_id << " (measured " << m.object_verified[i] << ")";
    }
    // Floors: ORB top-1 0.430, verified 0.482; SIFT top-1 0.492, verified 0.716.
    EXPECT_GE(total.Top1Rate(), FloorAboveChance(m.top1, kChance)) << detector;
    EXPECT_GE(total.VerifiedPrecision(), FloorAboveChance(m.verified, kChance)) << detector;
  }
}

TEST(ObjectPipelineTest, ClassesMapBackToTheRightObjectAndVoxel) {
  const ObjectDatabase& db = OrbDatabase();
  const ClassStack& s = db.stack();
  ASSERT_EQ(s.k(), 300);
  for (uint32_t c = 0; c < s.num_classes(); ++c) {
    if (!s.Valid(c)) continue;
    const StackedVoxel v = s.VoxelOf(c);
    EXPECT_EQ(s.ClassOf(v.object_index, v.rank), c);
    EXPECT_EQ(s.ObjectOf(c), v.object_index);
    EXPECT_EQ(&db.VoxelOfClass(c), &db.objects()[v.object_index].voxels[v.rank]);
  }
  // Stacking keeps the voxels with most evidence: ranks are in evidence order.
  for (const ObjectModel& o : db.objects()) {
    for (size_t j = 1; j < o.voxels.size(); ++j)
      EXPECT_GE(o.voxels[j - 1].evidence, o.voxels[j].evidence);
  }
  // Geometry: verified predictions on held-out views point at the voxel where the feature
  // really is (back-projected with the ground-truth pose), within a few voxels.
  absl::StatusOr<dataset::Sequence> seq = dataset::LoadBopScene(MiniDataset() + "/train/000002");
  ASSERT_TRUE(seq.ok()) << seq.status();
  auto extractor = FeatureExtractor::Create(db.params().features);
  ASSERT_TRUE(extractor.ok());
  const ObjectModel& cereal = db.objects()[1];
  std::vector<double> errors;
  double chance = 0;  // expected hit rate of a random stacked voxel of the object
  std::vector<float> scratch;
  Prediction p;
  for (const dataset::Frame& f : seq->frames) {
    if (!HeldOutView(2, f.id)) continue;
    auto img = dataset::LoadFrameImages(f, true);
    ASSERT_TRUE(img.ok());
    cv::Mat mask;
    cv::erode(img->masks[0], mask, cv::Mat(), {-1, -1}, 2);
    auto feats = (*extractor)->Extract(img->rgb, mask);
    ASSERT_TRUE(feats.ok());
    const Eigen::Isometry3d T_c2m = f.objects[0].T_m2c.inverse();
    for (size_t i = 0; i < feats->keypoints.size(); ++i) {
      const cv::Point2f& pt = feats->keypoints[i].pt;
      const double z = img->depth.at<uint16_t>(cvRound(pt.y), cvRound(pt.x)) * f.depth_scale * 1e-3;
      if (z <= 0 || !db.Recognize(feats->descriptors.Row(i), &scratch, &p) || p.obj_id != 2)
        continue;
      const Eigen::Vector3d truth =
          T_c2m * Eigen::Vector3d((pt.x - f.K.cx) * z / f.K.fx, (pt.y - f.K.cy) * z / f.K.fy, z);
      errors.push_back((p.point - truth).norm());
      int near = 0;
      for (int j = 0; j < db.stack().used(1); ++j) {
        near += (VoxelCenter(cereal.voxels[j].key, 0.01) - truth).norm() < 0.02;
      }
      chance += double(near) / db.stack().used(1);
    }
  }
  ASSERT_GE(errors.size(), 761u);  // measured 1142 verified predictions (2026-11-24); 2/3
  const double hits =
      std::count_if(errors.begin(), errors.end(), [](double e) { return e < 0.02; });
  const double rate = hits / errors.size();
  chance /= errors.size();
  // Measured 2026-11-24 (printed faces, 300 classes): 57.5 % of verified predictions land
  // within 2 cm of the true point, against 2.1 % for a random stacked voxel of the object:
  // 27 x chance. Floors: two thirds of the margin over chance (0.39), and 18 x chance (two
  // thirds of 27).
  std::printf("[ measured ] within 2 cm: %.3f, chance %.3f (%zu predictions)\n", rate, chance,
              errors.size());
  EXPECT_GE(rate, FloorAboveChance(0.575, chance));
  EXPECT_GE(rate, 18 * chance) << "chance " << chance;
}

TEST(ObjectPipelineTest, CentroidMemorySaturatesWhileRawDescriptorsGrowLinearly) {
  // Paper Fig. 4: more evidence of an object (denser views, then a second orbit — a
  // "variant") grows the raw descriptors linearly but the stored centroids less and less:
  // mean shift folds the new evidence into existing clusters (higher cardinality) instead
  // of adding memory. Evidence doubles at each step: 3, 6, 12 views of the first orbit
  // (120, 60, 30 degrees apart), then both orbits (24 views).
  //
  // Measured 2026-11-24 (deterministic), centroid bytes / raw bytes at 3, 6, 12, 24 views:
  //   boxgreen (1): 11160/17920, 20268/36320, 30024/73728, 50508/182176
  //     centroids x1.82, x1.48, then x1.68 for the variant; x4.53 overall, raw x10.2
  //   teabox (3):   25344/31008, 52920/67776, 85860/136832, 117756/333312
  //     centroids x2.09, x1.62, x1.37; x4.65 overall while raw grows x10.7
  // The variant (the second orbit, 45 degrees up) sees the printed top face the first orbit
  // barely saw: new surface rightly needs new centroids (the cereal box, object 2, is left
  // out for the same reason on a larger scale).
  // Bounds, lower is better, 4/3 of the measured values: centroid growth over raw growth
  // <= 0.593 / 0.580 (proportional growth gives 1); the variant's doubling <= x1.91 /
  // x1.49 (its excess over 1 times 4/3); and the last doubling grows less than the first.
  struct Case {
    int obj_id;
    double max_growth_ratio, max_last_growth;
  };
  absl::StatusOr<ObjectDatabaseParams> p = ResolveParams(Params("ORB"));
  ASSERT_TRUE(p.ok());
  for (const Case& c : {Case{1, 0.593, 1.91}, Case{3, 0.580, 1.49}}) {
    const std::string dir = absl::StrFormat("%s/train/%06d", MiniDataset(), c.obj_id);
    std::vector<ObjectTrainingStats> steps;
    constexpr std::pair<int, int> kViews[] = {{12, 4}, {12, 2}, {12, 1}, {24, 1}};  // id <, id %
    for (const std::pair<int, int>& v : kViews) {
      auto o = TrainObject(dir, c.obj_id, "", *p, {.use_frame = [v](int, int id) {
                             return id < v.first && id % v.second == 0;
                           }});
      ASSERT_TRUE(o.ok()) << o.status();
      steps.push_back(o->model.stats);
    }
    std::printf("[ measured ] object %d centroid/raw bytes:", c.obj_id);
    for (const ObjectTrainingStats& s : steps) {
      std::printf(" %lld/%lld", static_cast<long long>(s.centroid_bytes),
                  static_cast<long long>(s.raw_descriptor_bytes));
    }
    std::printf("\n");
    for (size_t i = 1; i < steps.size(); ++i) {
      EXPECT_EQ(steps[i].frames, 2 * steps[i - 1].frames);
      // Raw descriptors grow with the evidence: each doubling of views doubles them
      // (measured x2.02-x2.47).
      const double raw = double(steps[i].raw_descriptor_bytes) / steps[i - 1].raw_descriptor_bytes;
      EXPECT_GE(raw, 1.8) << "object " << c.obj_id << " step " << i;
      // Cardinality grows: each step stores fewer centroid bytes per raw byte.
      EXPECT_LT(double(steps[i].centroid_bytes) / steps[i].raw_descriptor_bytes,
                double(steps[i - 1].centroid_bytes) / steps[i - 1].raw_descriptor_bytes)
          << "object " << c.obj_id << " step " << i;
    }
    auto growth = [&](size_t from, size_t to, auto field) {
      return double(steps[to].*field) / steps[from].*field;
    };
    const double raw_growth = growth(0, 3, &ObjectTrainingStats::raw_descriptor_bytes);
    const double centroid_growth = growth(0, 3, &ObjectTrainingStats::centroid_bytes);
    EXPECT_LE(centroid_growth / raw_growth, c.max_growth_ratio) << "object " << c.obj_id;
    const double first = growth(0, 1, &ObjectTrainingStats::centroid_bytes);
    const double last = growth(2, 3, &ObjectTrainingStats::centroid_bytes);
    EXPECT_LE(last, c.max_last_growth) << "object " << c.obj_id;
    EXPECT_LT(last, first) << "object " << c.obj_id;
  }
}

TEST(ObjectPipelineTest, RgbVolumeHoldsTheObject) {
  const ObjectModel& o = OrbDatabase().objects().at(0);  // boxgreen: a textured 5 cm cube
  auto map = DeserializeMap<RGBWeightedVoxel>(o.rgb_volume, {});
  ASSERT_TRUE(map.ok()) << map.status();
  ASSERT_GE((*map)->size(), 90u);  // measured 136 voxels (2026-11-23); two thirds
  cv::Scalar mean(0, 0, 0);
  double weight = 0;
  (*map)->ForEach([&](const VoxelKey& k, const RGBWeightedVoxel& v) {
    // Model frame, origin at the cube centre: every voxel within the cube (+1.5 voxels).
    EXPECT_LT(VoxelCenter(k, 0.01).cwiseAbs().maxCoeff(), 0.025 + 0.015);
    mean += cv::Scalar(v.b, v.g, v.r);
    weight += v.weight;
  });
  // Its colour is the colour of the object's pixels (first training view). Measured
  // 2026-11-23: the volume is 12-14 levels darker per channel (it averages every training
  // view, lit from other sides); 4/3 of the largest is 19.
  absl::StatusOr<dataset::Sequence> seq = dataset::LoadBopScene(MiniDataset() + "/train/000001");
  ASSERT_TRUE(seq.ok());
  auto img = dataset::LoadFrameImages(seq->frames[0], true);
  ASSERT_TRUE(img.ok());
  const cv::Scalar pixels = cv::mean(img->rgb, img->masks[0]);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(mean[c] / weight, pixels[c], 19) << "channel " << c;
}

TEST(ObjectPipelineTest, DatabaseRoundTripsThroughSqlite) {
  const ObjectDatabase& db = OrbDatabase();
  const std::string path = testing::TempDir() + "/skimap.db";
  ASSERT_TRUE(SaveObjectDatabase(db, path).ok());
  absl::StatusOr<ObjectDatabase> back = LoadObjectDatabase(path);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_TRUE(*back == db);
  // Identical answers for the same descriptors.
  std::vector<float> s1, s2;
  std::vector<Prediction> a, b;
  const VoxelModel& v = db.objects()[1].voxels[0];
  for (size_t i = 0; i < v.centroids.rows(); ++i) {
    db.Classify(v.centroids.Row(i), &s1, &a);
    back->Classify(v.centroids.Row(i), &s2, &b);
    ASSERT_EQ(a.size(), b.size());
    for (size_t k = 0; k < a.size(); ++k) {
      EXPECT_EQ(a[k].cls, b[k].cls);
      EXPECT_EQ(a[k].confidence, b[k].confidence);
    }
  }
  // Saving again replaces (not appends).
  ASSERT_TRUE(SaveObjectDatabase(*back, path).ok());
  absl::StatusOr<ObjectDatabase> again = LoadObjectDatabase(path);
  ASSERT_TRUE(again.ok());
  EXPECT_TRUE(*again == db);
  EXPECT_EQ(LoadObjectDatabase(testing::TempDir() + "/empty.db").status().code(),
            absl::StatusCode::kNotFound);
}

}  // namespace
}  // namespace skimap::objects
