// The Voxel concept and the geometry voxels (WeightVoxel, RGBWeightedVoxel).
//
// A voxel type is a value with fusion arithmetic: integration is `voxel += data`,
// de-integration is `voxel -= data`, and a voxel whose IsEmpty() turns true is removed from
// the map (its memory reused). Weight() is the evidence the queries threshold on. Encode /
// Decode give the voxel's payload in the map file format (docs/formats.md), identified by
// kTypeId; HeapBytes() is memory the voxel owns outside itself, for memory accounting.
// A default-constructed voxel is empty and the identity of fusion: V() += d equals d (so
// V() += d is empty exactly when d is).
#ifndef SKIMAP_VOXEL_H_
#define SKIMAP_VOXEL_H_

#include <cmath>
#include <concepts>
#include <cstddef>
#include <cstdint>

#include "base/encoding.h"

namespace skimap {

template <class V>
concept Voxel = std::default_initializable<V> && std::copyable<V> &&
    requires(V v, const V& c, Encoder& e, Decoder& d) {
  v += c;
  v -= c;
  { c.IsEmpty() } -> std::convertible_to<bool>;
  { c.Weight() } -> std::convertible_to<float>;
  { c.HeapBytes() } -> std::convertible_to<size_t>;
  c.Encode(e);
  { V::Decode(d, &v) } -> std::convertible_to<bool>;
  { V::kTypeId } -> std::convertible_to<uint32_t>;
};

// Weights at or below this count as zero (absorbs float rounding of de-integration).
inline constexpr float kEmptyWeight = 1e-4f;

// Occupancy evidence only: the weight (number of observations, or any positive measure).
struct WeightVoxel {
  static constexpr uint32_t kTypeId = 1;
  float weight = 0;

  WeightVoxel& operator+=(const WeightVoxel& o) {
    weight += o.weight;
    return *this;
  }
  WeightVoxel& operator-=(const WeightVoxel& o) {
    weight -= o.weight;
    return *this;
  }
  bool IsEmpty() const { return weight <= kEmptyWeight; }
  float Weight() const { return weight; }
  size_t HeapBytes() const { return 0; }
  void Encode(Encoder& e) const { e.F32(weight); }
  // Rejects a non-finite weight (it would pass every weight threshold or none).
  static bool Decode(Decoder& d, WeightVoxel* v) {
    return d.F32(&v->weight) && std::isfinite(v->weight);
  }
};

// Weighted colour: sums of colour*weight and of weights, so that integration and
// de-integration are exact inverses (up to float rounding). Colour channels in [0, 255].
struct RGBWeightedVoxel {
  static constexpr uint32_t kTypeId = 2;
  float r = 0, g = 0, b = 0;  // sum of channel * weight
  float weight = 0;

  RGBWeightedVoxel() = default;
  // One observation of colour (r, g, b) with weight w.
  RGBWeightedVoxel(float red, float green, float blue, float w)
      : r(red * w), g(green * w), b(blue * w), weight(w) {}

  RGBWeightedVoxel& operator+=(const RGBWeightedVoxel& o) {
    r += o.r;
    g += o.g;
    b += o.b;
    weight += o.weight;
    return *this;
  }
  RGBWeightedVoxel& operator-=(const RGBWeightedVoxel& o) {
    r -= o.r;
    g -= o.g;
    b -= o.b;
    weight -= o.weight;
    return *this;
  }
  bool IsEmpty() const { return weight <= kEmptyWeight; }
  float Weight() const { return weight; }
  // Mean colour; 0 for an empty voxel.
  float Red() const { return weight > 0 ? r / weight : 0; }
  float Green() const { return weight > 0 ? g / weight : 0; }
  float Blue() const { return weight > 0 ? b / weight : 0; }
  size_t HeapBytes() const { return 0; }
  void Encode(Encoder& e) const {
    e.F32(r);
    e.F32(g);
    e.F32(b);
    e.F32(weight);
  }
  // Rejects non-finite sums (they would poison every mean colour and weight threshold).
  static bool Decode(Decoder& d, RGBWeightedVoxel* v) {
    return d.F32(&v->r) && d.F32(&v->g) && d.F32(&v->b) && d.F32(&v->weight) &&
           std::isfinite(v->r) && std::isfinite(v->g) && std::isfinite(v->b) &&
           std::isfinite(v->weight);
  }
};

}  // namespace skimap

#endif  // SKIMAP_VOXEL_H_
