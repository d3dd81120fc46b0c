// RandomForest: a compact random decision forest for many classes (thousands: m objects
// x k voxels), written for SkiMap++'s descriptor -> class prediction (paper §3, Eq. 2).
//
//   TrainingSet set{.dims = 256};  ... set.Add(features, label) ...
//   absl::StatusOr<RandomForest> f = RandomForest::Train(set, num_classes, {.trees = 24});
//   f->Predict(features, /*top_n=*/3, &scores);   // classes with confidence in [0, 1]
//
// Trees: axis-aligned splits x[f] < t, chosen per node among `features_per_split` random
// features x `thresholds_per_feature` random thresholds (midpoints of two random node
// samples' values) by the Gini criterion; each tree sees a bootstrap sample. Leaves keep a
// sparse class histogram (the `leaf_classes` most frequent classes, as fractions of the
// leaf's samples). The confidence of class c is the mean over trees of its leaf fraction.
// Why not cv::ml::RTrees: see docs/objects.md (memory and time at thousands of classes).
//
// Serialization: little-endian, versioned, CRC-32C (docs/objects.md, "forest blob").
//
// Thread safety: a trained forest is immutable; Predict may run concurrently.
#ifndef SKIMAP_PERCEPTION_OBJECTS_RANDOM_FOREST_H_
#define SKIMAP_PERCEPTION_OBJECTS_RANDOM_FOREST_H_

#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"

namespace skimap::objects {

struct ForestOptions {
  int trees = 24;                  // 1..1024 (paper: 24)
  int max_depth = 24;              // 1..64 (paper: 24); the root is depth 0
  int min_samples_split = 4;       // a node with fewer samples becomes a leaf; >= 2
  int features_per_split = 0;      // candidate features per node; 0 = sqrt(dims)
  int thresholds_per_feature = 2;  // random thresholds tried per candidate feature; >= 1
  double bootstrap_fraction = 1;   // samples drawn (with replacement) per tree / n; (0, 4]
  int leaf_classes = 8;            // classes kept per leaf; 1..255
  uint64_t seed = 1;               // same seed, same data, same options: same forest
  int threads = 2;                 // trees trained in parallel; >= 1
  friend bool operator==(const ForestOptions&, const ForestOptions&) = default;
};

// Row-major float features with one label each.
struct TrainingSet {
  int dims = 0;
  std::vector<float> features;  // size() == labels.size() * dims
  std::vector<uint32_t> labels;

  size_t size() const { return labels.size(); }
  void Add(std::span<const float> x, uint32_t label) {
    features.insert(features.end(), x.begin(), x.end());
    labels.push_back(label);
  }
};

// A class and its confidence (mean leaf fraction over the trees, in [0, 1]).
struct ClassScore {
  uint32_t cls = 0;
  float confidence = 0;
};

// Checks options; InvalidArgument naming the field.
absl::Status ValidateForestOptions(const ForestOptions& options);

class RandomForest {
 public:
  // Per-tree progress: fn(trees_done, trees_total); may be called from worker threads
  // (serialized).
  using Progress = std::function<void(int, int)>;

  RandomForest() = default;

  // Trains on `set` (REQUIRES labels < num_classes). InvalidArgument for bad options, an
  // empty set, inconsistent sizes or an out-of-range label.
  static absl::StatusOr<RandomForest> Train(const TrainingSet& set, uint32_t num_classes,
                                            const ForestOptions& options,
                                            const Progress& progress = nullptr);

  // The top_n classes by confidence for one feature vector of dims() floats, highest
  // first (ties: smaller class). `out` is cleared first; scratch reuse avoids allocation.
  void Predict(const float* features, int top_n, std::vector<ClassScore>* out) const;
  // Predict for n feature vectors (row i at features + i * dims()) at once: out[i] is
  // Predict(row i). Trees are walked one at a time for every row, so a tree's upper levels
  // stay in cache (several times faster than n Predict calls on a large forest).
  void PredictMany(const float* features, size_t n, int top_n,
                   std::vector<std::vector<ClassScore>>* out) const;
  // PredictMany for binary descriptors packed 8 bits a byte (bit f of row i is
  // (bits[i * row_bytes + f / 8] >> (f % 8)) & 1, as ToFeatures unpacks them), without
  // unpacking: a split x[f] < t reads the bit (exact for thresholds in (0, 1], which is what
  // training on 0/1 features yields). REQUIRES: dims() == 8 * row_bytes.
  void PredictManyBits(const uint8_t* bits, size_t row_bytes, size_t n, int top_n,
                       std::vector<std::vector<ClassScore>>* out) const;

  int dims() const { return dims_; }
  uint32_t num_classes() const { return num_classes_; }
  int num_trees() const { return static_cast<int>(roots_.size()); }
  size_t num_nodes() const { return nodes_.size(); }
  // Bytes of the model in memory (nodes + leaf entries).
  size_t MemoryBytes() const;

  std::string Serialize() const;
  // DataLoss for a bad checksum or truncation, InvalidArgument for a malformed model.
  static absl::StatusOr<RandomForest> Deserialize(std::string_view bytes);

  friend bool operator==(const RandomForest&, const RandomForest&) = default;

  // Internal layout (public for the trainer and the serializer).
  struct Node {
    int32_t feature = -1;  // -1: leaf
    float threshold = 0;   // go left if x[feature] < threshold
    uint32_t a = 0;        // split: right child index; leaf: first leaf entry
    uint32_t b = 0;        // split: left child index;  leaf: number of leaf entries
    friend bool operator==(const Node&, const Node&) = default;
  };
  struct LeafEntry {
    uint32_t cls = 0;
    float fraction = 0;
    friend bool operator==(const LeafEntry&, const LeafEntry&) = default;
  };

 private:
  // Top-n classes of each of n rows from their leaves (leaf[i * trees + t]).
  void MergeLeaves(const std::vector<uint32_t>& leaf, size_t n, int top_n,
                   std::vector<std::vector<ClassScore>>* out) const;
  int dims_ = 0;
  uint32_t num_classes_ = 0;
  std::vector<uint32_t> roots_;  // node index of each tree's root
  std::vector<Node> nodes_;
  std::vector<LeafEntry> leaves_;
};

}  // namespace skimap::objects

#endif  // SKIMAP_PERCEPTION_OBJECTS_RANDOM_FOREST_H_
