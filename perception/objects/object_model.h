// ObjectModel: what the database keeps of one trained object — its descriptor voxels
// reduced to mean-shift centroids (paper §3.1), ranked by evidence, and its RGB volume.
//
// Voxel keys are in the object (model) frame: key = floor(p_model / resolution), so the
// voxel centre is (key + 0.5) * resolution metres in the model frame (BOP model origin).
//
// Thread safety: plain values.
#ifndef SKIMAP_PERCEPTION_OBJECTS_OBJECT_MODEL_H_
#define SKIMAP_PERCEPTION_OBJECTS_OBJECT_MODEL_H_

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "perception/objects/descriptors.h"
#include "skimap/grid.h"

namespace skimap::objects {

// One descriptor voxel after mean shift.
struct VoxelModel {
  VoxelKey key;                         // object frame, at the database resolution
  uint32_t evidence = 0;                // raw descriptors fused into the voxel
  DescriptorMatrix centroids;           // mean-shift modes, one row each
  std::vector<uint32_t> cardinalities;  // points per centroid; sums to evidence
  friend bool operator==(const VoxelModel&, const VoxelModel&) = default;
};

// Training statistics of one object (for reports; not used by recognition).
struct ObjectTrainingStats {
  int64_t frames = 0;                // training frames fused
  int64_t features = 0;              // keypoints detected on the object
  int64_t descriptors = 0;           // descriptors fused (keypoints with valid depth)
  int64_t raw_descriptor_bytes = 0;  // payload of all fused descriptors
  int64_t centroid_bytes = 0;        // payload of all centroids (+ 4-byte cardinalities)
  friend bool operator==(const ObjectTrainingStats&, const ObjectTrainingStats&) = default;
};

struct ObjectModel {
  int obj_id = 0;    // dataset object id (BOP obj_id), unique in a database
  std::string name;  // display name ("" if unknown)
  // Every voxel with evidence, sorted by evidence (descending), ties by key: index = rank.
  std::vector<VoxelModel> voxels;
  // skimap::SerializeMap of the object's SkiMap<RGBWeightedVoxel> (model frame), for
  // display; "" if none was built.
  std::string rgb_volume;
  ObjectTrainingStats stats;

  friend bool operator==(const ObjectModel&, const ObjectModel&) = default;
};

// Centre of voxel `key` in the model frame (metres).
inline Eigen::Vector3d VoxelCenter(const VoxelKey& key, double resolution) {
  return {(key.x + 0.5) * resolution, (key.y + 0.5) * resolution, (key.z + 0.5) * resolution};
}

}  // namespace skimap::objects

#endif  // SKIMAP_PERCEPTION_OBJECTS_OBJECT_MODEL_H_
