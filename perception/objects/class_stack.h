// ClassStack: the SkiMap++ class stacking (paper §3, Fig. 3, Eq. 2-3). Per object the k
// voxels with the most evidence are kept (ranks j = 0..k-1 of ObjectModel::voxels); the
// stacks of the m objects are concatenated into one global class space:
//
//   c = object_index * k + j,   v(c) = voxel j of object c / k,   o(v) = c / k.
//
// An object with fewer than k voxels leaves classes o*k + n_o .. o*k + k-1 unused
// (Valid() is false for them; the forest never predicts them).
//
// Thread safety: an immutable value.
#ifndef SKIMAP_PERCEPTION_OBJECTS_CLASS_STACK_H_
#define SKIMAP_PERCEPTION_OBJECTS_CLASS_STACK_H_

#include <cstdint>
#include <vector>

#include "absl/status/statusor.h"

namespace skimap::objects {

// The (object, voxel rank) a class stands for.
struct StackedVoxel {
  int object_index = -1;  // position of the object in the database
  int rank = -1;          // j: index into that object's voxels (evidence order)
};

class ClassStack {
 public:
  ClassStack() = default;
  // k classes per object; voxels_per_object[o] = voxels object o has. InvalidArgument if
  // k < 1 or m * k does not fit in 2^31.
  static absl::StatusOr<ClassStack> Create(int k, const std::vector<int>& voxels_per_object);

  int k() const { return k_; }
  int num_objects() const { return static_cast<int>(used_.size()); }
  // m * k: the size of the class space (including unused classes).
  uint32_t num_classes() const { return static_cast<uint32_t>(used_.size()) * k_; }
  // Classes in use for object o: min(k, voxels of o).
  int used(int object_index) const { return used_[object_index]; }

  // c = o * k + j (REQUIRES: 0 <= o < num_objects(), 0 <= j < k).
  uint32_t ClassOf(int object_index, int rank) const {
    return static_cast<uint32_t>(object_index) * k_ + rank;
  }
  // o(v(c)) = c / k.
  int ObjectOf(uint32_t c) const { return static_cast<int>(c / k_); }
  // v(c): the (object, rank) of class c.
  StackedVoxel VoxelOf(uint32_t c) const {
    return {static_cast<int>(c / k_), static_cast<int>(c % k_)};
  }
  // True if c < num_classes() and its rank is below used(object).
  bool Valid(uint32_t c) const {
    return c < num_classes() && static_cast<int>(c % k_) < used_[c / k_];
  }

  friend bool operator==(const ClassStack&, const ClassStack&) = default;

 private:
  int k_ = 1;
  std::vector<int> used_;
};

}  // namespace skimap::objects

#endif  // SKIMAP_PERCEPTION_OBJECTS_CLASS_STACK_H_
