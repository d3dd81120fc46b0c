// RandomForest prediction, memory accounting and serialization.
#include <algorithm>
#include <cmath>
#include <limits>

#include "absl/strings/str_cat.h"
#include "base/encoding.h"
#include "perception/objects/random_forest.h"

namespace skimap::objects {
namespace {

constexpr char kForestMagic[4] = {'S', 'K', 'R', 'F'};
constexpr uint32_t kForestVersion = 1;

}  // namespace

void RandomForest::Predict(const float* x, int top_n, std::vector<ClassScore>* out) const {
  out->clear();
  if (roots_.empty() || top_n <= 0) return;
  // Leaf entries of all trees, merged by class (trees x leaf_classes entries at most).
  thread_local std::vector<LeafEntry> hits;
  hits.clear();
  for (uint32_t root : roots_) {
    const Node* n = &nodes_[root];
    while (n->feature >= 0) n = &nodes_[x[n->feature] < n->threshold ? n->b : n->a];
    hits.insert(hits.end(), leaves_.begin() + n->a, leaves_.begin() + n->a + n->b);
  }
  std::sort(hits.begin(), hits.end(),
            [](const LeafEntry& a, const LeafEntry& b) { return a.cls < b.cls; });
  const float inv_trees = 1.0f / static_cast<float>(roots_.size());
  for (size_t i = 0; i < hits.size();) {
    float sum = 0;
    const uint32_t c = hits[i].cls;
    for (; i < hits.size() && hits[i].cls == c; ++i) sum += hits[i].fraction;
    out->push_back({c, sum * inv_trees});
  }
  auto better = [](const ClassScore& a, const ClassScore& b) {
    return a.confidence != b.confidence ? a.confidence > b.confidence : a.cls < b.cls;
  };
  const size_t keep = std::min<size_t>(out->size(), static_cast<size_t>(top_n));
  std::partial_sort(out->begin(), out->begin() + keep, out->end(), better);
  out->resize(keep);
}

namespace {

// The leaf of every row in every tree, tree by tree (a tree's upper levels stay in cache):
// leaf[i * trees + t]. `feature(i, f)` reads feature f of row i. Rows go down a tree
// kBlock at a time, one level per pass over the block: the block's node loads do not
// depend on each other, so their cache misses overlap instead of queueing (a forest of a
// few thousand classes is megabytes; one row's walk is a chain of dependent misses).
template <class Feature>
void WalkTrees(const std::vector<uint32_t>& roots, const std::vector<RandomForest::Node>& nodes,
               size_t n, Feature feature, std::vector<uint32_t>* leaf) {
  constexpr size_t kBlock = 16;
  const size_t trees = roots.size();
  leaf->resize(n * trees);
  for (size_t t = 0; t < trees; ++t) {
    for (size_t first = 0; first < n; first += kBlock) {
      const size_t m = std::min(kBlock, n - first);
      uint32_t k[kBlock];
      std::fill(k, k + m, roots[t]);
      for (bool moved = true; moved;) {
        moved = false;
        for (size_t j = 0; j < m; ++j) {
          const RandomForest::Node& nd = nodes[k[j]];
          if (nd.feature < 0) continue;
          k[j] = feature(first + j, nd.feature) < nd.threshold ? nd.b : nd.a;
          moved = true;
        }
      }
      for (size_t j = 0; j < m; ++j) (*leaf)[(first + j) * trees + t] = k[j];
    }
  }
}

}  // namespace

void RandomForest::MergeLeaves(const std::vector<uint32_t>& leaf, size_t n, int top_n,
                               std::vector<std::vector<ClassScore>>* out) const {
  out->resize(n);
  for (std::vector<ClassScore>& o : *out) o.clear();
  if (roots_.empty() || top_n <= 0) return;
  const size_t trees = roots_.size();
  thread_local std::vector<LeafEntry> hits;
  const float inv_trees = 1.0f / static_cast<float>(trees);
  auto better = [](const ClassScore& a, const ClassScore& b) {
    return a.confidence != b.confidence ? a.confidence > b.confidence : a.cls < b.cls;
  };
  for (size_t i = 0; i < n; ++i) {
    hits.clear();
    for (size_t t = 0; t < trees; ++t) {
      const Node& nd = nodes_[leaf[i * trees + t]];
      hits.insert(hits.end(), leaves_.begin() + nd.a, leaves_.begin() + nd.a + nd.b);
    }
    std::sort(hits.begin(), hits.end(),
              [](const LeafEntry& a, const LeafEntry& b) { return a.cls < b.cls; });
    std::vector<ClassScore>& o = (*out)[i];
    for (size_t h = 0; h < hits.size();) {
      float sum = 0;
      const uint32_t c = hits[h].cls;
      for (; h < hits.size() && hits[h].cls == c; ++h) sum += hits[h].fraction;
      o.push_back({c, sum * inv_trees});
    }
    const size_t keep = std::min<size_t>(o.size(), static_cast<size_t>(top_n));
    std::partial_sort(o.begin(), o.begin() + keep, o.end(), better);
    o.resize(keep);
  }
}

void RandomForest::PredictMany(const float* features, size_t n, int top_n,
                               std::vector<std::vector<ClassScore>>* out) const {
  thread_local std::vector<uint32_t> leaf;
  const size_t dims = static_cast<size_t>(dims_);
  WalkTrees(
      roots_, nodes_, n, [&](size_t i, int f) { return features[i * dims + f]; }, &leaf);
  MergeLeaves(leaf, n, top_n, out);
}

void RandomForest::PredictManyBits(const uint8_t* bits, size_t row_bytes, size_t n, int top_n,
                                   std::vector<std::vector<ClassScore>>* out) const {
  thread_local std::vector<uint32_t> leaf;
  WalkTrees(
      roots_, nodes_, n,
      [&](size_t i, int f) {
        return static_cast<float>((bits[i * row_bytes + (f >> 3)] >> (f & 7)) & 1);
      },
      &leaf);
  MergeLeaves(leaf, n, top_n, out);
}

size_t RandomForest::MemoryBytes() const {
  return nodes_.size() * sizeof(Node) + leaves_.size() * sizeof(LeafEntry) +
         roots_.size() * sizeof(uint32_t);
}

std::string RandomForest::Serialize() const {
  std::string out;
  Encoder e(&out);
  e.Bytes(std::string_view(kForestMagic, 4));
  e.U32(kForestVersion);
  e.U32(static_cast<uint32_t>(dims_));
  e.U32(num_classes_);
  e.U32(static_cast<uint32_t>(roots_.size()));
  e.U64(nodes_.size());
  e.U64(leaves_.size());
  for (uint32_t r : roots_) e.U32(r);
  for (const Node& n : nodes_) {
    e.I32(n.feature);
    e.F32(n.threshold);
    e.U32(n.a);
    e.U32(n.b);
  }
  for (const LeafEntry& l : leaves_) {
    e.U32(l.cls);
    e.F32(l.fraction);
  }
  e.U32(Crc32c(out));
  return out;
}

absl::StatusOr<RandomForest> RandomForest::Deserialize(std::string_view bytes) {
  if (bytes.size() >= 4 && bytes.substr(0, 4) != std::string_view(kForestMagic, 4)) {
    return absl::InvalidArgumentError("forest blob: bad magic");
  }
  if (bytes.size() < 4 + 4 * 4 + 16 + 4) return absl::DataLossError("forest blob: truncated");
  const std::string_view body = bytes.substr(0, bytes.size() - 4);
  Decoder crc_in(bytes.substr(bytes.size() - 4));
  uint32_t crc = 0;
  (void)crc_in.U32(&crc);
  if (Crc32c(body) != crc) return absl::DataLossError("forest blob: checksum mismatch");
  Decoder d(body.substr(4));
  uint32_t version = 0, dims = 0, classes = 0, trees = 0;
  uint64_t nodes = 0, leaves = 0;
  if (!d.U32(&version) || !d.U32(&dims) || !d.U32(&classes) || !d.U32(&trees) || !d.U64(&nodes) ||
      !d.U64(&leaves)) {
    return absl::DataLossError("forest blob: truncated header");
  }
  if (version != kForestVersion) {
    return absl::InvalidArgumentError(
        absl::StrCat("forest blob: version ", version, " unsupported (want ", kForestVersion, ")"));
  }
  if (dims > uint32_t{std::numeric_limits<int32_t>::max()} ||
      classes > uint32_t{std::numeric_limits<int32_t>::max()}) {
    return absl::InvalidArgumentError("forest blob: dims or classes above 2^31 - 1");
  }
  // Each count must fit the bytes on its own before the sizes are added: a count near 2^60
  // would otherwise wrap the sum back to the real size and allocate that many nodes.
  const uint64_t remaining = d.remaining();
  if (nodes > remaining / 16 || leaves > remaining / 8 ||
      remaining != trees * 4ull + nodes * 16 + leaves * 8) {
    return absl::DataLossError("forest blob: size does not match its counts");
  }
  RandomForest f;
  f.dims_ = static_cast<int>(dims);
  f.num_classes_ = classes;
  f.roots_.resize(trees);
  f.nodes_.resize(nodes);
  f.leaves_.resize(leaves);
  for (uint32_t& r : f.roots_) (void)d.U32(&r);
  for (Node& n : f.nodes_)
    (void)(d.I32(&n.feature) && d.F32(&n.threshold) && d.U32(&n.a) && d.U32(&n.b));
  for (LeafEntry& l : f.leaves_) (void)(d.U32(&l.cls) && d.F32(&l.fraction));
  // Validate every index so that Predict can trust the model.
  for (uint32_t r : f.roots_) {
    if (r >= nodes) return absl::InvalidArgumentError("forest blob: root out of range");
  }
  for (size_t i = 0; i < f.nodes_.size(); ++i) {
    const Node& n = f.nodes_[i];
    if (n.feature >= 0) {
      // Children come after their parent (depth-first layout): no cycles. A non-finite
      // threshold would send every sample the same way.
      if (n.feature >= static_cast<int32_t>(dims) || n.a <= i || n.b <= i || n.a >= nodes ||
          n.b >= nodes || !std::isfinite(n.threshold)) {
        return absl::InvalidArgumentError(absl::StrCat("forest blob: node ", i, " malformed"));
      }
    } else if (n.feature != -1 || uint64_t{n.a} + n.b > leaves) {
      return absl::InvalidArgumentError(absl::StrCat("forest blob: leaf ", i, " malformed"));
    }
  }
  for (const LeafEntry& l : f.leaves_) {
    if (l.cls >= classes) return absl::InvalidArgumentError("forest blob: class out of range");
    if (!(l.fraction >= 0 && l.fraction <= 1)) {
      return absl::InvalidArgumentError("forest blob: leaf fraction outside [0, 1]");
    }
  }
  // A leaf's fractions share one unit (a class listed twice would predict above 1).
  for (uint64_t i = 0; i < nodes; ++i) {
    const Node& n = f.nodes_[i];
    if (n.feature != -1) continue;
    double sum = 0;
    for (uint64_t k = n.a; k < uint64_t{n.a} + n.b; ++k) sum += f.leaves_[k].fraction;
    if (sum > 1.0001) {
      return absl::InvalidArgumentError(
          absl::StrCat("forest blob: leaf ", i, " fractions sum to ", sum, " > 1"));
    }
  }
  return f;
}

}  // namespace skimap::objects
