// objects_bench: the object database benchmark (issue 5; docs/benchmarks.md, "Object
// database"). Trains the objects of a skimap-sim dataset with every Nth training view held
// out, then for each detector and each k (classes per object) reports training time,
// database size (SQLite file), forest prediction time per feature and per-object top-1
// accuracy on the held-out views; plus the paper's Fig. 4 memory check (raw descriptors
// vs mean-shift centroids as orbit variants are added).
//
//   build/sim/skimap-sim --preset sk --out /tmp/sk --scenes 0
//   build/bench/objects_bench --data /tmp/sk --detectors ORB,SIFT --k 50,100,200,400
//
// A program, not a test: prints markdown tables on stdout, progress on stderr.
#include <sys/resource.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/ml.hpp>
#include <string>
#include <vector>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "perception/objects/evaluation.h"
#include "perception/objects/random_forest.h"
#include "perception/objects/training.h"
#include "server/core/objects/object_database_io.h"

namespace fs = std::filesystem;
using namespace skimap::objects;

namespace {

struct Args {
  std::string data;
  std::vector<std::string> detectors = {"ORB", "SIFT"};
  std::vector<int> ks = {50, 100, 200, 400};
  int holdout = 4;  // frame_id % holdout == holdout - 1 is held out
  int trees = 24, depth = 24, threads = 2, max_features = 1000;
  double resolution = 0.01;
  double bandwidth = 0, verify = 0;  // 0: the detector's default
  std::string db_dir = "/tmp";
  bool memory = true;
  int memory_object = 0;               // 0: the first object
  bool rtrees = false;                 // only the forest comparison (ForestRow) on the same samples
  std::string rtrees_impl = "opencv";  // ForestRow: "opencv" (cv::ml::RTrees) or "ours"
};

double Seconds(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

bool ParseArgs(int argc, char** argv, Args* a) {
  for (int i = 1; i < argc; ++i) {
    const std::string k = argv[i];
    const std::string v = i + 1 < argc ? argv[i + 1] : "";
    auto next = [&] { return ++i < argc; };
    if (k == "--data" && next()) {
      a->data = v;
    } else if (k == "--detectors" && next()) {
      a->detectors = absl::StrSplit(v, ',');
    } else if (k == "--k" && next()) {
      a->ks.clear();
      for (absl::string_view s : absl::StrSplit(v, ',')) {
        int x = 0;
        if (!absl::SimpleAtoi(s, &x)) return false;
        a->ks.push_back(x);
      }
    } else if (k == "--holdout" && next()) {
      if (!absl::SimpleAtoi(v, &a->holdout) || a->holdout < 2) return false;
    } else if (k == "--trees" && next()) {
      if (!absl::SimpleAtoi(v, &a->trees)) return false;
    } else if (k == "--depth" && next()) {
      if (!absl::SimpleAtoi(v, &a->depth)) return false;
    } else if (k == "--threads" && next()) {
      if (!absl::SimpleAtoi(v, &a->threads)) return false;
    } else if (k == "--max-features" && next()) {
      if (!absl::SimpleAtoi(v, &a->max_features)) return false;
    } else if (k == "--resolution" && next()) {
      if (!absl::SimpleAtod(v, &a->resolution)) return false;
    } else if (k == "--bandwidth" && next()) {
      if (!absl::SimpleAtod(v, &a->bandwidth)) return false;
    } else if (k == "--verify" && next()) {
      if (!absl::SimpleAtod(v, &a->verify)) return false;
    } else if (k == "--db-dir" && next()) {
      a->db_dir = v;
    } else if (k == "--memory-object" && next()) {
      if (!absl::SimpleAtoi(v, &a->memory_object)) return false;
    } else if (k == "--rtrees") {
      a->rtrees = true;
    } else if (k == "--rtrees-impl" && next()) {
      a->rtrees_impl = v;
      if (v != "opencv" && v != "ours") return false;
    } else if (k == "--no-memory") {
      a->memory = false;
    } else {
      return false;
    }
  }
  return !a->data.empty();
}

ObjectDatabaseParams Params(const Args& a, const std::string& detector, int k) {
  ObjectDatabaseParams p;
  p.features = {.detector = detector, .max_features = a.max_features};
  p.resolution = a.resolution;
  p.classes_per_object = k;
  p.mean_shift.bandwidth = a.bandwidth;
  p.verify_threshold = a.verify;
  p.forest.trees = a.trees;
  p.forest.max_depth = a.depth;
  p.forest.threads = a.threads;
  return p;
}

// Fig. 4: raw descriptor bytes vs centroid bytes of one object as variants are added.
void MemoryTable(const Args& a, const std::string& detector, int obj_id) {
  char folder[16];
  std::snprintf(folder, sizeof(folder), "%06d", obj_id);
  const fs::path dir = fs::path(a.data) / "train" / folder;
  std::ifstream in(dir / "variants.json");
  const nlohmann::json variants = nlohmann::json::parse(in, nullptr, false);
  if (!variants.is_array()) return;
  std::printf("\n#### Fig. 4 check: %s, object %d, variants added one by one\n\n", detector.c_str(),
              obj_id);
  std::printf(
      "| variants | frames | descriptors | raw descriptor bytes | centroids | centroid bytes | "
      "ratio |\n");
  std::printf("|---|---|---|---|---|---|---|\n");
  absl::StatusOr<ObjectDatabaseParams> p = ResolveParams(Params(a, detector, 100));
  for (size_t n = 1; n <= variants.size(); ++n) {
    const int last = variants[n - 1]["first_id"].get<int>() + variants[n - 1]["count"].get<int>();
    DatasetTrainingOptions o{.use_frame = [&](int, int id) { return id < last; },
                             .threads = a.threads};
    absl::StatusOr<TrainedObject> t = TrainObject(dir.string(), obj_id, "", *p, o);
    if (!t.ok()) {
      std::cerr << t.status() << "\n";
      return;
    }
    int64_t centroids = 0;
    for (const VoxelModel& v : t->model.voxels) centroids += v.centroids.rows();
    const ObjectTrainingStats& s = t->model.stats;
    std::printf("| 1..%zu | %lld | %lld | %lld | %lld | %lld | %.2f |\n", n, (long long)s.frames,
                (long long)s.descriptors, (long long)s.raw_descriptor_bytes, (long long)centroids,
                (long long)s.centroid_bytes, double(s.centroid_bytes) / s.raw_descriptor_bytes);
  }
}

double PeakRssMb() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_maxrss / 1024.0;
}

double CpuSeconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_utime.tv_sec + u.ru_stime.tv_sec + 1e-6 * (u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

// One forest implementation on the stacked samples of k classes per object (the raw
// descriptors of each object's first k voxels, labels object * k + voxel): cv::ml::RTrees
// (--rtrees-impl=opencv) or our RandomForest (ours), trained with the same settings wherever
// both have one:
//   trees and max depth          --trees, --depth (24 x 24)
//   samples to split a node      >= 4 (RTrees setMinSampleCount, ours min_samples_split)
//   candidate features per node  round(sqrt(dims)) (RTrees' default, set explicitly;
//                                ours features_per_split), 16 for ORB's 256 bits
//   bootstrap                    n samples drawn with replacement per tree (both)
//   threads                      one (cv::setNumThreads(1); ours threads = 1): CPU and wall
//                                time are printed to show it
// What differs, by design of the libraries: RTrees tries every threshold of each candidate
// feature (sorts the node's values), ours thresholds_per_feature = 2 random midpoints; on
// ORB's binary features every threshold in (0, 1) is the same split, so both weigh the same
// 16 candidate splits per node (ours misses a feature when both draws see the same bit).
// RTrees' leaves keep one class (predict returns the majority vote), ours the 8 most frequent
// classes with fractions (top-n with confidence, what recognition needs). Run each
// implementation in a process of its own: the peak RSS growth is process-wide.
void ForestRow(const Args& a, const std::vector<TrainedObject>& trained, int k) {
  std::vector<float> x;
  std::vector<int> y;
  int dims = 0;
  for (size_t o = 0; o < trained.size(); ++o) {
    const int used = std::min<int>(k, static_cast<int>(trained[o].raw.size()));
    for (int j = 0; j < used; ++j) {
      const DescriptorMatrix& m = trained[o].raw[j];
      dims = m.layout().FeatureDims();
      std::vector<float> f(dims);
      for (size_t i = 0; i < m.rows(); ++i) {
        ToFeatures(m.layout(), m.Row(i), f);
        x.insert(x.end(), f.begin(), f.end());
        y.push_back(static_cast<int>(o) * k + j);
      }
    }
  }
  const int features_per_node = std::max(1, static_cast<int>(std::lround(std::sqrt(dims))));
  const int n = std::min<int>(2000, static_cast<int>(y.size()));
  const double rss0 = PeakRssMb();
  const double cpu0 = CpuSeconds();
  const auto t0 = std::chrono::steady_clock::now();
  double train_s = 0, train_cpu = 0, predict_us = 0, model_mb = -1;
  if (a.rtrees_impl == "opencv") {
    cv::setNumThreads(1);
    cv::Mat X(static_cast<int>(y.size()), dims, CV_32F, x.data()),
        Y(static_cast<int>(y.size()), 1, CV_32S, y.data());
    cv::Ptr<cv::ml::RTrees> rt = cv::ml::RTrees::create();
    rt->setMaxDepth(a.depth);
    rt->setMinSampleCount(4);
    rt->setActiveVarCount(features_per_node);
    rt->setUseSurrogates(false);
    rt->setCalculateVarImportance(false);
    rt->setTermCriteria({cv::TermCriteria::MAX_ITER, a.trees, 0});
    rt->train(cv::ml::TrainData::create(X, cv::ml::ROW_SAMPLE, Y));
    train_s = Seconds(t0);
    train_cpu = CpuSeconds() - cpu0;
    const auto t1 = std::chrono::steady_clock::now();
    for (int i = 0; i < n; ++i) rt->predict(X.row(i));
    predict_us = 1e6 * Seconds(t1) / n;
  } else {
    TrainingSet set{.dims = dims, .features = x, .labels = {}};
    set.labels.assign(y.begin(), y.end());
    const ForestOptions options{.trees = a.trees,
                                .max_depth = a.depth,
                                .min_samples_split = 4,
                                .features_per_split = features_per_node,
                                .threads = 1};
    absl::StatusOr<RandomForest> forest =
        RandomForest::Train(set, static_cast<uint32_t>(trained.size() * k), options);
    train_s = Seconds(t0);
    train_cpu = CpuSeconds() - cpu0;
    if (!forest.ok()) {
      std::cerr << forest.status() << "\n";
      return;
    }
    model_mb = forest->MemoryBytes() / 1e6;
    std::vector<ClassScore> scores;
    const auto t1 = std::chrono::steady_clock::now();
    for (int i = 0; i < n; ++i) forest->Predict(&x[size_t(i) * dims], 1, &scores);
    predict_us = 1e6 * Seconds(t1) / n;
  }
  std::printf(
      "| %s k=%d | %zu samples | %d features/node | train %.1f s wall, %.1f s CPU | peak RSS "
      "+%.0f MB | model %s MB | predict %.1f us (top class) |\n",
      a.rtrees_impl == "opencv" ? "cv::ml::RTrees" : "RandomForest (ours)", k, y.size(),
      features_per_node, train_s, train_cpu, PeakRssMb() - rss0,
      model_mb < 0 ? "?" : absl::StrCat(static_cast<int>(model_mb + 0.5)).c_str(), predict_us);
  std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) {
  Args a;
  if (!ParseArgs(argc, argv, &a)) {
    std::cerr << "usage: objects_bench --data DIR [--detectors ORB,SIFT] [--k 50,100,200,400]\n"
                 "  [--holdout 4] [--trees 24] [--depth 24] [--threads 2] [--max-features 1000]\n"
                 "  [--resolution 0.01] [--bandwidth B] [--verify T] [--db-dir /tmp] "
                 "[--no-memory]\n  [--memory-object ID] [--rtrees [--rtrees-impl opencv|ours]]\n";
    return 2;
  }
  absl::StatusOr<std::vector<std::pair<int, std::string>>> objects = ListTrainingObjects(a.data);
  if (!objects.ok()) {
    std::cerr << objects.status() << "\n";
    return 1;
  }
  const int h = a.holdout;
  auto train_frame = [h](int, int id) { return id % h != h - 1; };
  auto test_frame = [h](int, int id) { return id % h == h - 1; };
  for (const std::string& detector : a.detectors) {
    absl::StatusOr<ObjectDatabaseParams> base = ResolveParams(Params(a, detector, a.ks[0]));
    if (!base.ok()) {
      std::cerr << base.status() << "\n";
      return 1;
    }
    // Features + descriptor voxels + mean shift once per detector (independent of k).
    std::vector<TrainedObject> trained;
    const auto t0 = std::chrono::steady_clock::now();
    for (const auto& [id, name] : *objects) {
      char folder[16];
      std::snprintf(folder, sizeof(folder), "%06d", id);
      std::cerr << detector << ": training object " << id << " (" << name << ")\n";
      absl::StatusOr<TrainedObject> t =
          TrainObject((fs::path(a.data) / "train" / folder).string(), id, name, *base,
                      {.use_frame = train_frame, .threads = a.threads});
      if (!t.ok()) {
        std::cerr << t.status() << "\n";
        return 1;
      }
      trained.push_back(*std::move(t));
    }
    const double voxel_seconds = Seconds(t0);
    int64_t frames = 0, descriptors = 0, voxels = 0;
    for (const TrainedObject& t : trained) {
      frames += t.model.stats.frames;
      descriptors += t.model.stats.descriptors;
      voxels += static_cast<int64_t>(t.model.voxels.size());
    }
    std::printf(
        "\n### %s: %zu objects, %lld training views (%lld descriptors, %lld voxels), "
        "features + voxels + mean shift %.1f s; bandwidth %g, verify threshold %g\n\n",
        detector.c_str(), trained.size(), (long long)frames, (long long)descriptors,
        (long long)voxels, voxel_seconds, base->mean_shift.bandwidth, base->verify_threshold);
    if (a.rtrees) {
      for (int k : a.ks) ForestRow(a, trained, k);
      continue;
    }
    std::printf(
        "| k | classes | forest train s | forest MB | SQLite file MB | predict us/feature "
        "| feature top-1 | verified precision | view top-1 |\n");
    std::printf("|---|---|---|---|---|---|---|---|---|\n");
    std::map<int, std::vector<ObjectAccuracy>> per_k;
    for (int k : a.ks) {
      absl::StatusOr<std::unique_ptr<ObjectDatabaseBuilder>> b =
          ObjectDatabaseBuilder::Create(Params(a, detector, k));
      if (!b.ok()) {
        std::cerr << b.status() << "\n";
        return 1;
      }
      for (const TrainedObject& t : trained) (void)(*b)->AddObject(t);
      const auto t1 = std::chrono::steady_clock::now();
      absl::StatusOr<ObjectDatabase> db = (*b)->Build();
      const double forest_seconds = Seconds(t1);
      if (!db.ok()) {
        std::cerr << db.status() << "\n";
        return 1;
      }
      const std::string path =
          (fs::path(a.db_dir) / ("objects_bench_" + detector + "_" + std::to_string(k) + ".db"))
              .string();
      fs::remove(path);
      if (absl::Status s = SaveObjectDatabase(*db, path); !s.ok()) {
        std::cerr << s << "\n";
        return 1;
      }
      absl::StatusOr<std::vector<ObjectAccuracy>> acc =
          EvaluateViews(*db, a.data, {.use_frame = test_frame});
      if (!acc.ok()) {
        std::cerr << acc.status() << "\n";
        return 1;
      }
      const ObjectAccuracy t = Total(*acc);
      std::printf("| %d | %u | %.1f | %.1f | %.1f | %.1f | %.3f | %.3f | %.3f |\n", k,
                  db->stack().num_classes(), forest_seconds, db->forest().MemoryBytes() / 1e6,
                  fs::file_size(path) / 1e6,
                  1e6 * t.predict_seconds / std::max<int64_t>(1, t.features), t.Top1Rate(),
                  t.VerifiedPrecision(), t.ViewRate());
      std::fflush(stdout);
      per_k[k] = *std::move(acc);
    }
    std::printf(
        "\n#### %s: per-object feature top-1 accuracy on held-out views (view top-1 in "
        "brackets)\n\n| object |",
        detector.c_str());
    for (int k : a.ks) std::printf(" k=%d |", k);
    std::printf("\n|---|");
    for (size_t i = 0; i < a.ks.size(); ++i) std::printf("---|");
    std::printf("\n");
    for (size_t o = 0; o < trained.size(); ++o) {
      std::printf("| %d %s |", trained[o].model.obj_id, trained[o].model.name.c_str());
      for (int k : a.ks) {
        const ObjectAccuracy& x = per_k[k][o];
        std::printf(" %.2f (%d/%d) |", x.Top1Rate(), x.views_correct, x.views);
      }
      std::printf("\n");
    }
    if (a.memory && !objects->empty()) {
      MemoryTable(a, detector, a.memory_object > 0 ? a.memory_object : objects->front().first);
    }
    std::fflush(stdout);
  }
  return 0;
}
