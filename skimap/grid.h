// Voxel keys and the world <-> key conversion.
//
// A voxel key is the integer triple floor((p - origin) / resolution), per axis, so voxel k
// covers [origin + k*res, origin + (k+1)*res) and its centre is origin + (k + 0.5)*res.
// Floor (not truncation) makes negative coordinates correct: -0.001 m at 1 cm is key -1.
//
// Key range: every key component lies in [kMinKey, kMaxKey] = [-2^20, 2^20 - 1], i.e.
// about ±10.48 km at 1 cm, ±52 km at 5 cm, ±5.2 km at 5 mm around the origin. A point
// outside that range (or a NaN/inf coordinate) has no key: ToKey returns false and the
// batch and single-point APIs report it as an error; nothing ever wraps around.
//
// Thread safety: Grid is an immutable value; safe to share.
#ifndef SKIMAP_GRID_H_
#define SKIMAP_GRID_H_

#include <cmath>
#include <compare>
#include <cstdint>

namespace skimap {

inline constexpr int32_t kKeyBits = 21;
inline constexpr int32_t kMinKey = -(1 << (kKeyBits - 1));
inline constexpr int32_t kMaxKey = (1 << (kKeyBits - 1)) - 1;

struct VoxelKey {
  int32_t x = 0, y = 0, z = 0;
  friend auto operator<=>(const VoxelKey&, const VoxelKey&) = default;
};

// Equality without short-circuit branches (keys of neighbouring points differ
// unpredictably in one component; a branchy compare mispredicts).
inline bool SameKey(const VoxelKey& a, const VoxelKey& b) {
  return ((a.x ^ b.x) | (a.y ^ b.y) | (a.z ^ b.z)) == 0;
}

// Packs a key into 63 bits that sort like (x, y, z) lexicographically.
inline uint64_t PackKey(const VoxelKey& k) {
  auto u = [](int32_t v) { return static_cast<uint64_t>(v - kMinKey); };
  return (u(k.x) << (2 * kKeyBits)) | (u(k.y) << kKeyBits) | u(k.z);
}
inline VoxelKey UnpackKey(uint64_t p) {
  constexpr uint64_t mask = (uint64_t{1} << kKeyBits) - 1;
  return {static_cast<int32_t>((p >> (2 * kKeyBits)) & mask) + kMinKey,
          static_cast<int32_t>((p >> kKeyBits) & mask) + kMinKey,
          static_cast<int32_t>(p & mask) + kMinKey};
}

struct Point3 {
  double x = 0, y = 0, z = 0;
};

// An axis-aligned box of keys, bounds inclusive. Empty when any min > max.
struct KeyBox {
  VoxelKey min{kMinKey, kMinKey, kMinKey};
  VoxelKey max{kMaxKey, kMaxKey, kMaxKey};
  bool Contains(const VoxelKey& k) const {
    return k.x >= min.x && k.x <= max.x && k.y >= min.y && k.y <= max.y && k.z >= min.z &&
           k.z <= max.z;
  }
  bool empty() const { return min.x > max.x || min.y > max.y || min.z > max.z; }
};

class Grid {
 public:
  // REQUIRES: resolution > 0 and finite; origin finite.
  explicit Grid(double resolution, Point3 origin = {})
      : resolution_(resolution), inv_resolution_(1.0 / resolution), origin_(origin) {}

  double resolution() const { return resolution_; }
  double inv_resolution() const { return inv_resolution_; }  // the factor keys use
  const Point3& origin() const { return origin_; }

  // Key of the voxel holding world coordinate v on one axis; false if out of key range.
  bool AxisToKey(double v, double origin, int32_t* key) const {
    const double f = (v - origin) * inv_resolution_;
    // The negated comparison also rejects NaN.
    if (!(f >= kMinKey && f < static_cast<double>(kMaxKey) + 1.0)) return false;
    int32_t i = static_cast<int32_t>(f);
    i -= (f < i);  // floor for negatives
    *key = i;
    return true;
  }
  bool ToKey(double x, double y, double z, VoxelKey* key) const {
    return AxisToKey(x, origin_.x, &key->x) && AxisToKey(y, origin_.y, &key->y) &&
           AxisToKey(z, origin_.z, &key->z);
  }
  bool ToKey(const Point3& p, VoxelKey* key) const { return ToKey(p.x, p.y, p.z, key); }

  // Centre of a voxel in world coordinates.
  double AxisCenter(int32_t k, double origin) const { return origin + (k + 0.5) * resolution_; }
  Point3 Center(const VoxelKey& k) const {
    return {AxisCenter(k.x, origin_.x), AxisCenter(k.y, origin_.y), AxisCenter(k.z, origin_.z)};
  }

  // Keys whose voxel centres lie in [lo, hi] on one axis (may be empty: *first > *last),
  // clamped to the key range. Inlined arithmetic, no libm calls: it runs once per column in
  // radius searches.
  void CenterRange(double lo, double hi, double origin, int32_t* first, int32_t* last) const {
    *first = ClampedCeil((lo - origin) * inv_resolution_ - 0.5);
    *last = ClampedFloor((hi - origin) * inv_resolution_ - 0.5);
  }

 private:
  // floor / ceil into [kMinKey - 1, kMaxKey + 1] (NaN gives an empty range).
  static int32_t ClampedFloor(double v) {
    if (!(v >= kMinKey)) return v >= kMinKey - 1.0 ? kMinKey - 1 : (v < 0 ? kMinKey - 1 : kMaxKey);
    if (v > kMaxKey) return kMaxKey;
    int32_t i = static_cast<int32_t>(v);
    return i - (v < i);
  }
  static int32_t ClampedCeil(double v) {
    if (!(v <= kMaxKey)) return v <= kMaxKey + 1.0 ? kMaxKey + 1 : (v > 0 ? kMaxKey + 1 : kMinKey);
    if (v < kMinKey) return kMinKey;
    int32_t i = static_cast<int32_t>(v);
    return i + (v > i);
  }

  double resolution_;
  double inv_resolution_;
  Point3 origin_;
};

}  // namespace skimap

#endif  // SKIMAP_GRID_H_
