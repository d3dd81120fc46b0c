// Mean shift clustering of the descriptors of one voxel (paper §3 and §3.1: the
// multi-modal "Descriptor Matrix" is replaced by its cluster centroids and cardinalities).
//
// Float descriptors: classic mean shift in R^n with the Euclidean distance; a flat kernel
// (mean of the points within `bandwidth`) or a Gaussian kernel (sigma = bandwidth,
// truncated at 3 sigma). Binary descriptors: mean shift in Hamming space: the "mean" of a
// set of bit strings is the per-bit (weighted) majority vote, i.e. the bit string that
// minimises the summed squared distance in the unpacked {0,1}^n space, where the squared
// Euclidean distance equals the Hamming distance. Centroids therefore stay binary and are
// verified with the Hamming distance.
//
// Procedure: every point (or max_seeds points evenly spaced in input order) seeds a
// trajectory; each shifts until it stops moving (or max_iterations); modes closer than
// bandwidth / 2 are merged (the mode with more support wins); every point is assigned to
// its nearest mode and modes without points are dropped. Deterministic.
//
// Thread safety: reentrant.
#ifndef SKIMAP_PERCEPTION_OBJECTS_MEAN_SHIFT_H_
#define SKIMAP_PERCEPTION_OBJECTS_MEAN_SHIFT_H_

#include <cstdint>
#include <vector>

#include "absl/status/statusor.h"
#include "perception/objects/descriptors.h"

namespace skimap::objects {

enum class MeanShiftKernel : uint8_t { kFlat = 0, kGaussian = 1 };

struct MeanShiftOptions {
  double bandwidth = 64;  // descriptor distance units: bits (binary) or L2 (float); > 0
  MeanShiftKernel kernel = MeanShiftKernel::kFlat;
  int max_iterations = 30;  // per seed, >= 1
  int max_seeds = 64;       // seeds per call, >= 1
  friend bool operator==(const MeanShiftOptions&, const MeanShiftOptions&) = default;
};

// Centroids (one row each, the input's layout) and how many input points each took.
struct Clusters {
  DescriptorMatrix centroids;
  std::vector<uint32_t> cardinalities;  // same length as centroids.rows(), each > 0
};

// Clusters `points`. Empty input gives empty clusters. InvalidArgument naming the field
// for a bad option.
absl::StatusOr<Clusters> MeanShift(const DescriptorMatrix& points, const MeanShiftOptions& options);

// Checks options (bandwidth > 0 and finite, max_iterations >= 1, max_seeds >= 1).
absl::Status ValidateMeanShiftOptions(const MeanShiftOptions& options);

}  // namespace skimap::objects

#endif  // SKIMAP_PERCEPTION_OBJECTS_MEAN_SHIFT_H_
