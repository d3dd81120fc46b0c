// The vertices of an object model file (a BOP models/obj_XXXXXX.ply, ASCII or binary, or
// any mesh format Assimp reads), in metres in the model frame: what pose-error metrics
// that compare transformed model points (BOP's MSSD) need.
//
//   absl::StatusOr<std::vector<Eigen::Vector3d>> p = LoadModelPoints(model.ply_path);
//
// Thread safety: reentrant.
#ifndef SKIMAP_DATASET_MODEL_POINTS_H_
#define SKIMAP_DATASET_MODEL_POINTS_H_

#include <string>
#include <vector>

#include "Eigen/Core"
#include "absl/status/statusor.h"

namespace skimap::dataset {

// Every vertex of every mesh in the file, scaled by `scale` (BOP models are in
// millimetres: 0.001 gives metres). When the file has more than `max_points` vertices, an
// even subset of max_points of them (every n-th in file order; max_points <= 0: all).
// Errors: NotFound for a missing file, InvalidArgument naming the file for one Assimp
// cannot read or that has no vertex.
absl::StatusOr<std::vector<Eigen::Vector3d>> LoadModelPoints(const std::string& path,
                                                             double scale = 0.001,
                                                             int max_points = 0);

// OK unless `path` is a PLY file whose header Assimp must not be given: one that is not
// whole within 64 KiB (Assimp 5.2 loops forever on some) or whose element counts cannot
// fit the bytes after it (Assimp allocates what a header claims). InvalidArgument naming
// the file. Other formats: OK (Assimp's own checks apply).
absl::Status CheckPlyHeader(const std::string& path);

}  // namespace skimap::dataset

#endif  // SKIMAP_DATASET_MODEL_POINTS_H_
