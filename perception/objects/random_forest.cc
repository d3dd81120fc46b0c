// RandomForest training (prediction and serialization: random_forest_predict.cc).
#include "perception/objects/random_forest.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <mutex>
#include <random>
#include <thread>

#include "absl/strings/str_cat.h"

namespace skimap::objects {
namespace {

using Node = RandomForest::Node;
using LeafEntry = RandomForest::LeafEntry;

// Grows one tree over a bootstrap sample. Nodes are laid out depth-first.
class TreeBuilder {
 public:
  TreeBuilder(const TrainingSet& set, uint32_t num_classes, const ForestOptions& o, uint64_t seed)
      : set_(set), o_(o), rng_(seed), count_(num_classes, 0), left_(num_classes, 0) {
    const int dims = set.dims;
    features_ = o.features_per_split > 0
                    ? std::min(o.features_per_split, dims)
                    : std::max(1, static_cast<int>(std::lround(std::sqrt(dims))));
  }

  void Build(std::vector<Node>* nodes, std::vector<LeafEntry>* leaves) {
    nodes_ = nodes;
    leaves_ = leaves;
    const size_t n = set_.size();
    const size_t draws = std::max<size_t>(1, static_cast<size_t>(o_.bootstrap_fraction * n));
    std::uniform_int_distribution<size_t> pick(0, n - 1);
    idx_.resize(draws);
    for (size_t& i : idx_) i = pick(rng_);
    values_.resize(draws);
    labels_.resize(draws);
    Grow(0, draws, 0);
  }

 private:
  float X(size_t sample, int f) const { return set_.features[sample * set_.dims + f]; }

  void Grow(size_t begin, size_t end, int depth) {
    const size_t n = end - begin;
    // Class counts of this node (touched list for a cheap reset).
    touched_.clear();
    double sum_sq = 0;
    for (size_t i = begin; i < end; ++i) {
      const uint32_t c = set_.labels[idx_[i]];
      labels_[i] = c;
      if (count_[c] == 0) touched_.push_back(c);
      sum_sq += 2.0 * count_[c] + 1;
      ++count_[c];
    }
    const bool pure = touched_.size() == 1;
    int best_f = -1;
    float best_t = 0;
    if (!pure && depth < o_.max_depth && n >= static_cast<size_t>(o_.min_samples_split)) {
      FindSplit(begin, end, sum_sq, &best_f, &best_t);
    }
    if (best_f < 0) {
      EmitLeaf(n);
      return;
    }
    for (uint32_t c : touched_) count_[c] = 0;
    const size_t mid =
        static_cast<size_t>(std::partition(idx_.begin() + begin, idx_.begin() + end,
                                           [&](size_t s) { return X(s, best_f) < best_t; }) -
                            idx_.begin());
    const size_t self = nodes_->size();
    nodes_->push_back({best_f, best_t, 0, 0});
    (*nodes_)[self].b = static_cast<uint32_t>(nodes_->size());
    Grow(begin, mid, depth + 1);
    (*nodes_)[self].a = static_cast<uint32_t>(nodes_->size());
    Grow(mid, end, depth + 1);
  }

  // Best (feature, threshold) by weighted Gini; best_f stays -1 if no split separates.
  // REQUIRES: count_ holds this node's class counts, sum_sq = sum of count^2, touched_ its
  // classes, labels_[begin, end) its samples' labels.
  void FindSplit(size_t begin, size_t end, double sum_sq, int* best_f, float* best_t) {
    const size_t n = end - begin;
    // Impurity * n = n - sum_sq / n; minimise the children's sum.
    double best = n - sum_sq / n - 1e-9;
    std::uniform_int_distribution<int> pick_f(0, set_.dims - 1);
    std::uniform_int_distribution<size_t> pick_s(begin, end - 1);
    for (int fi = 0; fi < features_; ++fi) {
      const int f = pick_f(rng_);
      // The gather over raw pointers: under ASan an out-of-line X() per sample took a
      // quarter of a forest's training.
      const float* column = set_.features.data() + f;
      const size_t dims = static_cast<size_t>(set_.dims);
      const size_t* idx = idx_.data();
      float* values = values_.data();
      for (size_t i = begin; i < end; ++i) values[i] = column[idx[i] * dims];
      for (int ti = 0; ti < o_.thresholds_per_feature; ++ti) {
        float a = values_[pick_s(rng_)], b = values_[pick_s(rng_)];
        for (int retry = 0; retry < 4 && a == b; ++retry) b = values_[pick_s(rng_)];
        if (a == b) break;  // (nearly) constant feature here
        const float t = 0.5f * (a + b) > std::min(a, b) ? 0.5f * (a + b) : std::max(a, b);
        // Left counts incrementally: sum of left^2 and of total*left.
        double nl = 0, sl = 0, cross = 0;
        for (size_t i = begin; i < end; ++i) {
          if (values_[i] < t) {
            const uint32_t c = labels_[i];
            sl += 2.0 * left_[c] + 1;
            cross += count_[c];
            ++left_[c];
            ++nl;
          }
        }
        for (uint32_t c : touched_) left_[c] = 0;
        const double nr = n - nl;
        if (nl == 0 || nr == 0) continue;
        const double sr = sum_sq - 2 * cross + sl;
        const double score = (nl - sl / nl) + (nr - sr / nr);
        if (score < best) {
          best = score;
          *best_f = f;
          *best_t = t;
        }
      }
    }
  }

  // A leaf from count_ (this node's counts); resets count_.
  void EmitLeaf(size_t n) {
    std::sort(touched_.begin(), touched_.end(), [&](uint32_t a, uint32_t b) {
      return count_[a] != count_[b] ? count_[a] > count_[b] : a < b;
    });
    const size_t keep = std::min<size_t>(touched_.size(), o_.leaf_classes);
    Node leaf{-1, 0, static_cast<uint32_t>(leaves_->size()), static_cast<uint32_t>(keep)};
    for (size_t i = 0; i < keep; ++i) {
      const uint32_t c = touched_[i];
      leaves_->push_back({c, static_cast<float>(count_[c]) / static_cast<float>(n)});
    }
    for (uint32_t c : touched_) count_[c] = 0;
    nodes_->push_back(leaf);
  }

  const TrainingSet& set_;
  const ForestOptions& o_;
  std::mt19937_64 rng_;
  int features_ = 1;
  std::vector<uint32_t> count_;  // per class, this node (zero outside Grow)
  std::vector<uint32_t> left_;   // per class, left side of a candidate split
  std::vector<uint32_t> touched_;
  std::vector<size_t> idx_;
  std::vector<float> values_;
  std::vector<uint32_t> labels_;  // labels_[i] = set_.labels[idx_[i]], set per node by Grow
  std::vector<Node>* nodes_ = nullptr;
  std::vector<LeafEntry>* leaves_ = nullptr;
};

}  // namespace

absl::Status ValidateForestOptions(const ForestOptions& o) {
  auto bad = [](const char* field, auto value, const char* want) {
    return absl::InvalidArgumentError(absl::StrCat(field, ": ", value, " must be ", want));
  };
  if (o.trees < 1 || o.trees > 1024) return bad("trees", o.trees, "in 1..1024");
  if (o.max_depth < 1 || o.max_depth > 64) return bad("max_depth", o.max_depth, "in 1..64");
  if (o.min_samples_split < 2) return bad("min_samples_split", o.min_samples_split, ">= 2");
  if (o.features_per_split < 0) return bad("features_per_split", o.features_per_split, ">= 0");
  if (o.thresholds_per_feature < 1) {
    return bad("thresholds_per_feature", o.thresholds_per_feature, ">= 1");
  }
  if (!(o.bootstrap_fraction > 0 && o.bootstrap_fraction <= 4)) {
    return bad("bootstrap_fraction", o.bootstrap_fraction, "in (0, 4]");
  }
  if (o.leaf_classes < 1 || o.leaf_classes > 255) {
    return bad("leaf_classes", o.leaf_classes, "in 1..255");
  }
  if (o.threads < 1) return bad("threads", o.threads, ">= 1");
  return absl::OkStatus();
}

absl::StatusOr<RandomForest> RandomForest::Train(const TrainingSet& set, uint32_t num_classes,
                                                 const ForestOptions& options,
                                                 const Progress& progress) {
  if (absl::Status s = ValidateForestOptions(options); !s.ok()) return s;
  if (set.dims <= 0) return absl::InvalidArgumentError("training set: dims must be > 0");
  if (set.size() == 0) return absl::InvalidArgumentError("training set: no samples");
  if (set.features.size() != set.size() * set.dims) {
    return absl::InvalidArgumentError("training set: features.size() != labels * dims");
  }
  if (num_classes == 0) return absl::InvalidArgumentError("num_classes: must be > 0");
  for (uint32_t l : set.labels) {
    if (l >= num_classes) {
      return absl::InvalidArgumentError(
          absl::StrCat("training set: label ", l, " >= num_classes ", num_classes));
    }
  }
  std::vector<std::vector<Node>> nodes(options.trees);
  std::vector<std::vector<LeafEntry>> leaves(options.trees);
  std::atomic<int> next{0};
  std::mutex progress_mu;
  int done = 0;
  auto worker = [&] {
    for (int t = next++; t < options.trees; t = next++) {
      TreeBuilder builder(set, num_classes, options, options.seed * 0x9E3779B97F4A7C15ull + t);
      builder.Build(&nodes[t], &leaves[t]);
      std::lock_guard<std::mutex> lock(progress_mu);
      ++done;
      if (progress) progress(done, options.trees);
    }
  };
  const int threads = std::min(options.threads, options.trees);
  std::vector<std::thread> pool;
  for (int i = 1; i < threads; ++i) pool.emplace_back(worker);
  worker();
  for (std::thread& t : pool) t.join();

  RandomForest f;
  f.dims_ = set.dims;
  f.num_classes_ = num_classes;
  for (int t = 0; t < options.trees; ++t) {
    const uint32_t node_base = static_cast<uint32_t>(f.nodes_.size());
    const uint32_t leaf_base = static_cast<uint32_t>(f.leaves_.size());
    f.roots_.push_back(node_base);
    for (Node n : nodes[t]) {
      if (n.feature < 0) {
        n.a += leaf_base;
      } else {
        n.a += node_base;
        n.b += node_base;
      }
      f.nodes_.push_back(n);
    }
    f.leaves_.insert(f.leaves_.end(), leaves[t].begin(), leaves[t].end());
  }
  return f;
}

}  // namespace skimap::objects
