// DescriptorVoxel: the SkiMap++ "Descriptor Matrix" voxel (paper §3, Fig. 2): every
// descriptor observed at this voxel of an object, in object coordinates, from all views.
//
//   SkiMap<DescriptorVoxel> volume({.resolution = 0.01});
//   volume.IntegrateKey(key, DescriptorVoxel::One(layout, descriptor));   // voxel += {d}
//
// Fusion is multiset union (+=) and multiset difference (-=: each descriptor of the
// operand removes one bitwise-equal descriptor, if present), so de-integration is exact.
// Weight() is the number of descriptors: the voxel's evidence, used by class stacking.
// Satisfies skimap::Voxel; kTypeId 16 in the map file format (docs/objects.md).
//
// Thread safety: a value; concurrent const access is safe.
#ifndef SKIMAP_PERCEPTION_OBJECTS_DESCRIPTOR_VOXEL_H_
#define SKIMAP_PERCEPTION_OBJECTS_DESCRIPTOR_VOXEL_H_

#include <cstdint>

#include "base/encoding.h"
#include "perception/objects/descriptors.h"
#include "skimap/voxel.h"

namespace skimap::objects {

class DescriptorVoxel {
 public:
  static constexpr uint32_t kTypeId = 16;

  DescriptorVoxel() = default;
  // A voxel holding one descriptor.
  static DescriptorVoxel One(const DescriptorLayout& layout, DescriptorRef d);

  // Multiset union. An empty operand is a no-op; REQUIRES: same layout when both non-empty.
  DescriptorVoxel& operator+=(const DescriptorVoxel& o);
  // Multiset difference (one bitwise-equal row removed per operand row).
  DescriptorVoxel& operator-=(const DescriptorVoxel& o);

  const DescriptorMatrix& descriptors() const { return descriptors_; }
  bool IsEmpty() const { return descriptors_.empty(); }
  // Number of descriptors.
  float Weight() const { return static_cast<float>(descriptors_.rows()); }
  size_t HeapBytes() const { return descriptors_.HeapBytes(); }
  void Encode(Encoder& e) const { descriptors_.Encode(e); }
  static bool Decode(Decoder& d, DescriptorVoxel* v) {
    return DescriptorMatrix::Decode(d, &v->descriptors_);
  }

  friend bool operator==(const DescriptorVoxel&, const DescriptorVoxel&) = default;

 private:
  DescriptorMatrix descriptors_;
};

static_assert(skimap::Voxel<DescriptorVoxel>);

}  // namespace skimap::objects

#endif  // SKIMAP_PERCEPTION_OBJECTS_DESCRIPTOR_VOXEL_H_
