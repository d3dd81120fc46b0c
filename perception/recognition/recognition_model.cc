#include "perception/recognition/recognition_model.h"

#include <algorithm>
#include <limits>
#include <vector>

#include "Eigen/Eigenvalues"
#include "absl/container/flat_hash_set.h"
#include "absl/strings/str_cat.h"
#include "base/encoding.h"
#include "skimap/serialization.h"
#include "skimap/voxel.h"

namespace skimap::recognition {
namespace {

// The normal of a voxel surface at key `k`: the least-variance axis of the occupied voxels
// within 2 voxels; zero when fewer than 6 lie there or they are not flat (the two smaller
// variances alike: a rod or a blob, where no plane is defined). `occupied` holds PackKey
// values; neighbours beyond the key range are not looked up (their packing would alias
// other keys).
Eigen::Vector3f VoxelNormal(const absl::flat_hash_set<uint64_t>& occupied, const VoxelKey& k) {
  constexpr int kReach = 2;
  auto in_range = [](int32_t v) { return v >= kMinKey && v <= kMaxKey; };
  Eigen::Vector3f sum = Eigen::Vector3f::Zero();
  Eigen::Matrix3f outer = Eigen::Matrix3f::Zero();
  int n = 0;
  for (int dx = -kReach; dx <= kReach; ++dx) {
    for (int dy = -kReach; dy <= kReach; ++dy) {
      for (int dz = -kReach; dz <= kReach; ++dz) {
        const VoxelKey q{k.x + dx, k.y + dy, k.z + dz};
        if (!in_range(q.x) || !in_range(q.y) || !in_range(q.z) || !occupied.contains(PackKey(q))) {
          continue;
        }
        const Eigen::Vector3f d(dx, dy, dz);
        sum += d;
        outer += d * d.transpose();
        ++n;
      }
    }
  }
  if (n < 6) return Eigen::Vector3f::Zero();
  const Eigen::Vector3f mean = sum / n;
  const Eigen::Matrix3f cov = outer / n - mean * mean.transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3f> eig(cov);  // eigenvalues ascending
  if (eig.info() != Eigen::Success || !(eig.eigenvalues()(0) < 0.5f * eig.eigenvalues()(1))) {
    return Eigen::Vector3f::Zero();
  }
  return eig.eigenvectors().col(0).normalized();
}

// Bounding box of the object's trained surface in the model frame: its RGB volume when it
// has one, else its descriptor voxels. `surface` gets up to kSurfacePoints of the RGB
// volume's voxels, evenly taken, and *area the RGB volume's voxels times a voxel's face.
void Extent(const objects::ObjectModel& o, double resolution, Eigen::Vector3f* lo,
            Eigen::Vector3f* hi, std::vector<SurfacePoint>* surface, float* area) {
  *lo = Eigen::Vector3f::Constant(std::numeric_limits<float>::max());
  *hi = -*lo;
  auto add = [&](const Eigen::Vector3f& p) {
    *lo = lo->cwiseMin(p);
    *hi = hi->cwiseMax(p);
  };
  if (!o.rgb_volume.empty()) {
    absl::StatusOr<std::unique_ptr<SkiMap<RGBWeightedVoxel>>> rgb =
        DeserializeMap<RGBWeightedVoxel>(o.rgb_volume, {});
    if (rgb.ok() && !(*rgb)->empty()) {
      const double r = (*rgb)->grid().resolution();
      // A stored resolution is finite and positive, but may be absurd: an area that is not
      // a finite float is unknown (0).
      const double a = static_cast<double>((*rgb)->size()) * r * r;
      *area = a <= std::numeric_limits<float>::max() ? static_cast<float>(a) : 0.0f;
      const size_t step = std::max<size_t>(1, (*rgb)->size() / kSurfacePoints);
      absl::flat_hash_set<uint64_t> occupied;
      std::vector<VoxelKey> keys;
      size_t i = 0;
      (*rgb)->ForEach([&](const VoxelKey& k, const RGBWeightedVoxel& v) {
        const Eigen::Vector3f p = objects::VoxelCenter(k, r).cast<float>();
        add(p);
        occupied.insert(PackKey(k));
        if (i++ % step == 0 && surface->size() < kSurfacePoints) {
          surface->push_back({p, Eigen::Vector3f(v.Red(), v.Green(), v.Blue())});
          keys.push_back(k);
        }
      });
      for (size_t j = 0; j < keys.size(); ++j)
        (*surface)[j].normal = VoxelNormal(occupied, keys[j]);
      return;
    }
  }
  for (const objects::VoxelModel& v : o.voxels)
    add(objects::VoxelCenter(v.key, resolution).cast<float>());
  if (o.voxels.empty()) *lo = *hi = Eigen::Vector3f::Zero();
}

}  // namespace

absl::StatusOr<RecognitionModel> RecognitionModel::Create(
    std::shared_ptr<const objects::ObjectDatabase> db, const std::vector<int>& obj_ids) {
  RecognitionModel m;
  m.db_ = std::move(db);
  const objects::ObjectDatabase& d = *m.db_;
  const double res = d.params().resolution;
  for (const objects::ObjectModel& o : d.objects()) {
    ObjectShape s;
    s.obj_id = o.obj_id;
    s.name = o.name;
    s.wanted = obj_ids.empty();
    Eigen::Vector3f lo, hi;
    Extent(o, res, &lo, &hi, &s.surface, &s.surface_area);
    s.centre = (lo + hi) / 2;
    s.base = {s.centre.x(), s.centre.y(), lo.z()};
    s.half_extent = (hi - lo) / 2;
    s.radius = std::max(0.5f * (hi - lo).norm(), float(res));
    m.objects_.push_back(std::move(s));
  }
  for (size_t i = 0; i < obj_ids.size(); ++i) {
    const int index = d.FindObject(obj_ids[i]);
    if (index < 0) {
      return absl::InvalidArgumentError(absl::StrCat("recognition.obj_ids[", i, "]: object ",
                                                     obj_ids[i], " is not in the classifier"));
    }
    m.objects_[index].wanted = true;
  }
  const objects::ClassStack& stack = d.stack();
  m.class_points_.assign(stack.num_classes(), Eigen::Vector3f::Zero());
  m.class_object_.assign(stack.num_classes(), -1);
  for (uint32_t c = 0; c < stack.num_classes(); ++c) {
    if (!stack.Valid(c)) continue;
    m.class_points_[c] = objects::VoxelCenter(d.VoxelOfClass(c).key, res).cast<float>();
    m.class_object_[c] = stack.ObjectOf(c);
  }
  // Fingerprint: the forest (it fixes the classes) and the class points it maps to.
  std::string bytes = d.forest().Serialize();
  Encoder e(&bytes);
  for (const objects::ObjectModel& o : d.objects()) e.U32(static_cast<uint32_t>(o.obj_id));
  e.U32(static_cast<uint32_t>(stack.k()));
  for (const Eigen::Vector3f& p : m.class_points_) {
    for (int i = 0; i < 3; ++i) e.F32(p[i]);
  }
  m.fingerprint_ = (uint64_t{Crc32c(bytes)} << 32) | Crc32c(bytes, 0x9e3779b9u);
  return m;
}

}  // namespace skimap::recognition
