#include "perception/objects/class_stack.h"

#include <algorithm>

#include "absl/strings/str_cat.h"

namespace skimap::objects {

absl::StatusOr<ClassStack> ClassStack::Create(int k, const std::vector<int>& voxels_per_object) {
  if (k < 1) {
    return absl::InvalidArgumentError(absl::StrCat("classes_per_object: ", k, " must be >= 1"));
  }
  if (static_cast<int64_t>(k) * static_cast<int64_t>(voxels_per_object.size()) >= (1LL << 31)) {
    return absl::InvalidArgumentError(absl::StrCat("classes_per_object: ", k, " x ",
                                                   voxels_per_object.size(),
                                                   " objects exceeds 2^31 classes"));
  }
  ClassStack s;
  s.k_ = k;
  s.used_.reserve(voxels_per_object.size());
  for (int n : voxels_per_object) s.used_.push_back(std::clamp(n, 0, k));
  return s;
}

}  // namespace skimap::objects
