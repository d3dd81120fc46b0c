// vote_probe: online recognition's voting replayed offline on a BOP scene with its true
// camera poses, to see where robot-view recognition fails. Every frame is observed (the
// server's LabelObserver) and its labels fused into a Labels volume as the map does; at
// every n-th frame the active sphere is placed as the map places it, the label matches
// gathered, and VotePoses run per object; for each annotated object in view it reports,
// by distance (0.5 m bins): its matches in the sphere, how many of them lie within 2 cm of
// where the true pose puts their class point (inliers), and the frames with a hypothesis
// within 3 cm / 10 deg of the truth. Diagnostic: docs/recognition.md ("Robot view").
//
//   build/bench/bench/vote_probe --db=DATA_DIR/objects.sqlite --scene=DATASET/test/000001
//       [--every=10] [--triples=N] [--bin=M] [--consistency=0.03] [--inlier=0.02]
// (triples, bin, the sphere and the labels' voxel: the map's defaults unless given)
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "absl/flags/flag.h"
#include "absl/flags/parse.h"
#include "absl/strings/str_format.h"
#include "bench/probe_frames.h"
#include "dataset/reader.h"
#include "perception/recognition/active_sphere.h"
#include "perception/recognition/instance_estimator.h"
#include "perception/recognition/label_observer.h"
#include "perception/recognition/pose_voting.h"
#include "perception/recognition/recognition_model.h"
#include "server/core/objects/object_database_io.h"
#include "server/core/recognition/recognition_config.h"
#include "skimap/skimap.h"

ABSL_FLAG(std::string, db, "", "object database (a skimapd data dir's objects.sqlite)");
ABSL_FLAG(std::string, scene, "", "BOP scene folder");
ABSL_FLAG(int, every, 10, "statistics at every n-th frame");
ABSL_FLAG(int, vote_every, 1, "vote at every n-th frame (the map: every frame)");
ABSL_FLAG(int, max_frames, 0, "frames at most (0 = all)");
ABSL_FLAG(int, triples, 0, "triples per object and frame (0 = the map's default)");
ABSL_FLAG(double, bin, 0, "Hough bin, metres (0 = the map's default)");
ABSL_FLAG(double, consistency, 0.03, "VotingOptions.consistency");
ABSL_FLAG(double, min_side, 0.02, "VotingOptions.min_side");
ABSL_FLAG(double, inlier, 0.02, "VotingOptions.inlier_distance");
ABSL_FLAG(double, labels_resolution, 0.005, "Labels volume voxel, metres");

namespace {

using namespace skimap;  // NOLINT: a small diagnostic program

[[noreturn]] void Die(const std::string& what) {
  std::fprintf(stderr, "vote_probe: %s\n", what.c_str());
  std::exit(1);
}

struct Bin {
  int samples = 0, found = 0;
  double matches = 0, inliers = 0, inliers4 = 0, in_sphere = 0;
};

float AngleDeg(const Eigen::Matrix3f& R) {
  return std::acos(std::clamp((R.trace() - 1) / 2, -1.0f, 1.0f)) * 57.29578f;
}

}  // namespace

int main(int argc, char** argv) {
  absl::ParseCommandLine(argc, argv);
  absl::StatusOr<objects::ObjectDatabase> loaded =
      objects::LoadObjectDatabase(absl::GetFlag(FLAGS_db));
  if (!loaded.ok()) Die(loaded.status().ToString());
  auto db = std::make_shared<const objects::ObjectDatabase>(*std::move(loaded));
  absl::StatusOr<recognition::RecognitionModel> model =
      recognition::RecognitionModel::Create(db, {});
  if (!model.ok()) Die(model.status().ToString());
  recognition::LabelObserver observer(*model);
  absl::StatusOr<dataset::Sequence> seq = dataset::LoadBopScene(absl::GetFlag(FLAGS_scene));
  if (!seq.ok()) Die(seq.status().ToString());
  SkiMap<MultiLabelVoxel> labels(
      SkiMap<MultiLabelVoxel>::Options{.resolution = absl::GetFlag(FLAGS_labels_resolution)});
  recognition::VotingOptions voting;
  const server::RecognitionConfig map_defaults;  // what a map gets (recognition_config.h)
  voting.triples =
      absl::GetFlag(FLAGS_triples) > 0 ? absl::GetFlag(FLAGS_triples) : map_defaults.triples;
  voting.bin = static_cast<float>(absl::GetFlag(FLAGS_bin) > 0 ? absl::GetFlag(FLAGS_bin)
                                                               : map_defaults.hough_bin);
  voting.consistency = static_cast<float>(absl::GetFlag(FLAGS_consistency));
  voting.min_side = static_cast<float>(absl::GetFlag(FLAGS_min_side));
  voting.inlier_distance = static_cast<float>(absl::GetFlag(FLAGS_inlier));
  std::map<int, Bin> bins;
  std::map<int, Bin> per_object;                                       // the same, by obj_id
  std::map<int, std::vector<recognition::HypothesisSample>> all_hyps;  // per object index
  double labels_per_frame = 0;
  int n = static_cast<int>(seq->frames.size());
  if (absl::GetFlag(FLAGS_max_frames) > 0) n = std::min(n, absl::GetFlag(FLAGS_max_frames));
  for (int i = 0; i < n; ++i) {
    const dataset::Frame& f = seq->frames[i];
    absl::StatusOr<perception::RgbdFrame> frame = bench::ProbeFrame(f);
    if (!frame.ok()) Die(frame.status().ToString());
    absl::StatusOr<recognition::LabelObservations> obs = observer.Observe(*frame, 0.1, 5.0);
    if (!obs.ok()) Die(obs.status().ToString());
    labels_per_frame += obs->labels.size();
    VoxelBatch<MultiLabelVoxel> batch;
    recognition::AddLabels(*obs, frame->pose, labels.grid(), &batch);
    batch.Finalize();
    labels.Integrate(batch);
    if (i % absl::GetFlag(FLAGS_vote_every) != 0) continue;
    const bool stats = i % absl::GetFlag(FLAGS_every) == 0;
    const recognition::Sphere sphere = recognition::ActiveSphere(
        frame->pose, *obs, map_defaults.sphere_distance, map_defaults.sphere_radius);
    std::vector<std::vector<recognition::LabelMatch>> matches(model->num_objects());
    labels.RadiusSearch(
        Point3{sphere.centre.x(), sphere.centre.y(), sphere.centre.z()}, sphere.radius,
        [&](const VoxelKey& k, const MultiLabelVoxel& voxel) {
          const MultiLabelVoxel::Entry e = voxel.Heaviest();
          const Point3 c = labels.grid().Center(k);
          Eigen::Vector3f v;
          int o;
          if (!model->ClassPoint(e.label, &v, &o)) return;
          matches[o].push_back({Eigen::Vector3f(c.x, c.y, c.z), v, static_cast<float>(e.count)});
        });
    std::mt19937_64 rng(i * 0x9e3779b97f4a7c15ull + 1);
    for (int o = 0; o < model->num_objects(); ++o) {
      if (matches[o].size() < 3) continue;
      for (const recognition::PoseEstimate& e :
           recognition::VotePoses(matches[o], model->object(o), sphere, voting, rng)) {
        all_hyps[o].push_back({e.pose.translation(), Eigen::Quaternionf(e.pose.linear()), e.score,
                               static_cast<uint64_t>(i + 1)});
      }
    }
    if (!stats) continue;
    for (const dataset::ObjectAnnotation& a : f.objects) {
      if (a.px_count_visib < 100) continue;
      int o = -1;
      for (int k = 0; k < model->num_objects(); ++k) {
        if (model->object(k).obj_id == a.obj_id) o = k;
      }
      if (o < 0) continue;
      const Eigen::Isometry3f T_wm = (f.T_wc * a.T_m2c).cast<float>();
      Bin& b = bins[static_cast<int>(a.T_m2c.translation().norm() / 0.5)];
      Bin& po = per_object[a.obj_id];
      ++po.samples;
      po.matches += matches[o].size();
      po.in_sphere += a.T_m2c.translation().norm();  // (summed distance, printed as a mean)
      ++b.samples;
      b.in_sphere += (T_wm.translation() - sphere.centre).norm() < sphere.radius;
      b.matches += matches[o].size();
      for (const recognition::LabelMatch& m : matches[o]) {
        const float off = (T_wm * m.model - m.world).norm();
        b.inliers += off < 0.02f;
        b.inliers4 += off < 0.04f;
        po.inliers += off < 0.02f;
        po.inliers4 += off < 0.04f;
      }
      if (matches[o].size() < 3) continue;
      for (const recognition::PoseEstimate& e :
           recognition::VotePoses(matches[o], model->object(o), sphere, voting, rng)) {
        if ((e.pose.translation() - T_wm.translation()).norm() < 0.03f &&
            AngleDeg(e.pose.linear().transpose() * T_wm.linear()) < 10) {
          ++b.found;
          ++po.found;
          break;
        }
      }
    }
  }
  std::printf(
      "%d frames, %.0f labels per frame; voting: %d triples, bin %.3f, consistency "
      "%.3f, min side %.3f, inlier %.3f\n",
      n, labels_per_frame / std::max(n, 1), voting.triples, voting.bin, voting.consistency,
      voting.min_side, voting.inlier_distance);
  std::printf(
      "| distance (m) | object views | in the sphere | its matches in the sphere | "
      "inliers under the true pose (2 cm) | (4 cm) | views with a true hypothesis |\n"
      "|---|---|---|---|---|---|---|\n");
  for (const auto& [k, b] : bins) {
    const double s = std::max(b.samples, 1);
    std::printf("| %.1f-%.1f | %d | %.2f | %.0f | %.1f | %.1f | %.2f |\n", k * 0.5, k * 0.5 + 0.5,
                b.samples, b.in_sphere / s, b.matches / s, b.inliers / s, b.inliers4 / s,
                b.found / s);
  }
  std::printf(
      "\n| obj_id | views | mean distance (m) | matches | inliers (2 cm) | (4 cm) | views with a "
      "true hypothesis |\n|---|---|---|---|---|---|---|\n");
  for (const auto& [id, b] : per_object) {
    const double s = std::max(b.samples, 1);
    std::printf("| %d | %d | %.2f | %.0f | %.1f | %.1f | %.2f |\n", id, b.samples, b.in_sphere / s,
                b.matches / s, b.inliers / s, b.inliers4 / s, b.found / s);
  }
  // The map's instance step, once at the end, around each truth.
  std::printf(
      "\n| obj_id | hypotheses within 30 cm | ... within 3 cm / 10 deg of the truth | "
      "best estimate's error (mm, deg), support, frames |\n|---|---|---|---|\n");
  const dataset::Frame& f0 = seq->frames.front();
  for (const dataset::ObjectAnnotation& a : f0.objects) {
    const int o = model->FindObject(a.obj_id);
    if (o < 0) continue;
    const Eigen::Isometry3f T_wm = (f0.T_wc * a.T_m2c).cast<float>();
    std::vector<recognition::HypothesisSample> near;
    int good = 0;
    for (const recognition::HypothesisSample& h : all_hyps[o]) {
      const float dt = (h.t - T_wm.translation()).norm();
      if (dt > 0.3f) continue;
      near.push_back(h);
      good += dt < 0.03f && AngleDeg(h.q.toRotationMatrix().transpose() * T_wm.linear()) < 10;
    }
    const float r = std::max(0.3f * model->object(o).radius, 0.03f);
    std::string best = "-";
    for (const recognition::InstanceEstimate& e :
         recognition::EstimateInstances(near, {.radius = r})) {
      const float dt = (e.t - T_wm.translation()).norm();
      if (dt > 0.1f) continue;
      best = absl::StrFormat("%.0f, %.1f, %d, %d", dt * 1000,
                             AngleDeg(e.q.toRotationMatrix().transpose() * T_wm.linear()),
                             e.support, e.frames);
      break;
    }
    std::printf("| %d | %zu | %d | %s |\n", a.obj_id, near.size(), good, best.c_str());
  }
  return 0;
}
