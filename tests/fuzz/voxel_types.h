// The voxel types a stored volume can hold, by index, for the fuzz targets that decode
// volumes (skimap_file_fuzz.cc, chunk_codec_fuzz.cc): VisitVoxelType(i, fn) calls
// fn(V{}) for the i-th type (i modulo the count).
//
// Thread safety: pure.
#ifndef TESTS_FUZZ_VOXEL_TYPES_H_
#define TESTS_FUZZ_VOXEL_TYPES_H_

#include "perception/objects/descriptor_voxel.h"
#include "skimap/free_columns_voxel.h"
#include "skimap/hypotheses_voxel.h"
#include "skimap/label_voxel.h"
#include "skimap/voxel.h"

namespace skimap::fuzz {

inline constexpr int kVoxelTypes = 7;

template <class Fn>
void VisitVoxelType(int i, Fn&& fn) {
  switch (i % kVoxelTypes) {
    case 0:
      return fn(WeightVoxel{});
    case 1:
      return fn(RGBWeightedVoxel{});
    case 2:
      return fn(MultiLabelVoxel{});
    case 3:
      return fn(HypothesesVoxel{});
    case 4:
      return fn(InstancesVoxel{});
    case 5:
      return fn(FreeColumnsVoxel{});
    default:
      return fn(objects::DescriptorVoxel{});
  }
}

}  // namespace skimap::fuzz

#endif  // TESTS_FUZZ_VOXEL_TYPES_H_
