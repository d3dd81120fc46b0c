// A small but complete ORB object database for tests that need one without training:
// objects with obj_ids 10, 11, ..., each with the given descriptor voxels (one class per
// voxel, a random centroid each) and a 3-tree forest trained on random bit prototypes.
//
//   ObjectDatabase db = SmallOrbDatabase({{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}});
//
// Thread safety: pure functions (fixed seeds: the same database every call).
#ifndef TESTS_PERCEPTION_OBJECTS_SMALL_DATABASE_H_
#define TESTS_PERCEPTION_OBJECTS_SMALL_DATABASE_H_

#include <vector>

#include "perception/objects/object_database.h"
#include "perception/objects/random_forest.h"

namespace skimap::objects {

inline constexpr int kSmallDims = 256;  // ORB: 256 bits, one 0/1 feature each

// A forest of 3 trees (depth 8) over `classes` classes of kSmallDims features.
RandomForest SmallOrbForest(int classes);

// REQUIRES: every object has the same number of voxels (the classes per object), >= 1.
// `with_surface`: each object also gets an RGB volume (grey, at the database's 1 cm, or at
// `surface_resolution` metres when > 0: a stored volume's own, however absurd) of exactly
// its descriptor voxels, so the recognition model has surface points for it.
ObjectDatabase SmallOrbDatabase(const std::vector<std::vector<VoxelKey>>& voxels_per_object,
                                bool with_surface = false, double surface_resolution = 0);

}  // namespace skimap::objects

#endif  // TESTS_PERCEPTION_OBJECTS_SMALL_DATABASE_H_
