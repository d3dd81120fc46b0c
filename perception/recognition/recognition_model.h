// RecognitionModel: what online recognition (paper §4) needs of an ObjectDatabase, worked
// out once per map: which objects the map looks for, each object's extent in its model
// frame (the base point it votes for, its radius), and each class's voxel centre v(c).
//
//   absl::StatusOr<RecognitionModel> m = RecognitionModel::Create(db, {3, 5});
//   Eigen::Vector3f v; int object;
//   if (m->ClassPoint(c, &v, &object) && m->object(object).wanted) { ... }
//
// Thread safety: immutable after Create; share it freely.
#ifndef PERCEPTION_RECOGNITION_RECOGNITION_MODEL_H_
#define PERCEPTION_RECOGNITION_RECOGNITION_MODEL_H_

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "Eigen/Core"
#include "absl/status/statusor.h"
#include "perception/objects/object_database.h"

namespace skimap::recognition {

// A point of an object's trained surface (its RGB volume), model frame, with its colour
// and the surface's normal there (unit, either sign: the least-variance axis of the
// trained voxels within 2 cm; zero where they do not span a plane, e.g. a thin rod).
struct SurfacePoint {
  Eigen::Vector3f p = Eigen::Vector3f::Zero();
  Eigen::Vector3f rgb = Eigen::Vector3f::Zero();  // 0..255
  Eigen::Vector3f normal = Eigen::Vector3f::Zero();
};

struct ObjectShape {
  int obj_id = 0;
  std::string name;
  bool wanted = false;  // the map looks for it
  // In the model frame, metres: the centre of the bounding box of the object's trained
  // surface, its base (the bottom face's centre: the rigid point hypotheses vote for, paper
  // §4.2) and half its diagonal.
  Eigen::Vector3f centre = Eigen::Vector3f::Zero();
  Eigen::Vector3f base = Eigen::Vector3f::Zero();
  Eigen::Vector3f half_extent = Eigen::Vector3f::Zero();  // of the bounding box, about centre
  float radius = 0;
  // Up to kSurfacePoints points of the trained surface, evenly taken (for verifying a pose
  // against the map's RGB volume); empty when the object has no RGB volume.
  std::vector<SurfacePoint> surface;
  // The trained surface's area, m²: its RGB volume's voxels times a voxel's face; 0
  // without one, or when that is not a finite float (an absurd stored resolution).
  float surface_area = 0;
};

inline constexpr size_t kSurfacePoints = 400;

class RecognitionModel {
 public:
  // `obj_ids`: the objects to look for (empty: all). InvalidArgument naming
  // "recognition.obj_ids[i]" for an id the database does not hold. REQUIRES: db non-null.
  static absl::StatusOr<RecognitionModel> Create(std::shared_ptr<const objects::ObjectDatabase> db,
                                                 const std::vector<int>& obj_ids);

  const objects::ObjectDatabase& db() const { return *db_; }
  int num_objects() const { return static_cast<int>(objects_.size()); }
  // By class-stack index (the database's object order).
  const ObjectShape& object(int index) const { return objects_[index]; }
  // Index of the object with this dataset id, or -1.
  int FindObject(int obj_id) const { return db_->FindObject(obj_id); }

  // v(c) in the model frame and o(v(c)); false for a class the stack does not use.
  bool ClassPoint(uint32_t c, Eigen::Vector3f* point, int* object_index) const {
    if (c >= class_points_.size() || class_object_[c] < 0) return false;
    *point = class_points_[c];
    *object_index = class_object_[c];
    return true;
  }

  // Identifies the database (its objects, parameters and forest): a map's labels mean
  // something only with the database that made them.
  uint64_t fingerprint() const { return fingerprint_; }

 private:
  std::shared_ptr<const objects::ObjectDatabase> db_;
  std::vector<ObjectShape> objects_;
  std::vector<Eigen::Vector3f> class_points_;  // by class
  std::vector<int> class_object_;              // by class; -1 unused
  uint64_t fingerprint_ = 0;
};

}  // namespace skimap::recognition

#endif  // PERCEPTION_RECOGNITION_RECOGNITION_MODEL_H_
