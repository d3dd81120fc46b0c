#include "perception/objects/descriptor_voxel.h"

namespace skimap::objects {

DescriptorVoxel DescriptorVoxel::One(const DescriptorLayout& layout, DescriptorRef d) {
  DescriptorVoxel v;
  v.descriptors_ = DescriptorMatrix(layout);
  v.descriptors_.Append(d);
  return v;
}

DescriptorVoxel& DescriptorVoxel::operator+=(const DescriptorVoxel& o) {
  descriptors_.AppendAll(o.descriptors_);
  return *this;
}

DescriptorVoxel& DescriptorVoxel::operator-=(const DescriptorVoxel& o) {
  for (size_t i = 0; i < o.descriptors_.rows() && !descriptors_.empty(); ++i) {
    const long at = descriptors_.Find(o.descriptors_.Row(i));
    if (at >= 0) descriptors_.SwapRemove(static_cast<size_t>(at));
  }
  return *this;
}

}  // namespace skimap::objects
