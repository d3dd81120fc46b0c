#include "perception/row_projection.h"

#include <bit>
#include <cstring>

#include "skimap/grid.h"

#if defined(__x86_64__)
#include <immintrin.h>
#define SKIMAP_ROW_PROJECTION_AVX2 1
#endif

namespace skimap::perception {
namespace {

constexpr double kLowest = kMinKey;                                  // f >= kLowest and
constexpr double kPastHighest = static_cast<double>(kMaxKey) + 1.0;  // f < kPastHighest

// floor(g) for g in [kLowest, kPastHighest) (Grid::AxisToKey's).
int32_t FloorKey(double g) {
  int32_t i = static_cast<int32_t>(g);
  i -= (g < i);
  return i;
}

#ifdef SKIMAP_ROW_PROJECTION_AVX2

// Byte j of kSpread[m] is bit j of m.
constexpr uint32_t kSpread[16] = {
    0x00000000, 0x00000001, 0x00000100, 0x00000101, 0x00010000, 0x00010001, 0x00010100, 0x00010101,
    0x01000000, 0x01000001, 0x01000100, 0x01000101, 0x01010000, 0x01010001, 0x01010100, 0x01010101};

// Grid coordinate (v - origin) * inv of 4 points z * (base + ray) + t on one axis.
__attribute__((target("avx2"))) inline __m256d AxisCoordinate(__m256d z, double base,
                                                              const double* ray, double t,
                                                              double origin, double inv) {
  const __m256d v =
      _mm256_add_pd(_mm256_mul_pd(z, _mm256_add_pd(_mm256_set1_pd(base), _mm256_loadu_pd(ray))),
                    _mm256_set1_pd(t));
  return _mm256_mul_pd(_mm256_sub_pd(v, _mm256_set1_pd(origin)), _mm256_set1_pd(inv));
}

// All-ones lanes where f is in the key range (false for NaN: ordered compares).
__attribute__((target("avx2"))) inline __m256d InKeyRange(__m256d f) {
  return _mm256_and_pd(_mm256_cmp_pd(f, _mm256_set1_pd(kLowest), _CMP_GE_OQ),
                       _mm256_cmp_pd(f, _mm256_set1_pd(kPastHighest), _CMP_LT_OQ));
}

// floor of 4 coordinates where `use` is set, 0 elsewhere.
__attribute__((target("avx2"))) inline __m128i FloorKeys(__m256d f, __m256d use) {
  const __m256d g = _mm256_and_pd(f, use);  // +0.0 where not used (NaN included)
  const __m256d truncated = _mm256_cvtepi32_pd(_mm256_cvttpd_epi32(g));
  const __m256d below = _mm256_and_pd(_mm256_cmp_pd(g, truncated, _CMP_LT_OQ), _mm256_set1_pd(1.0));
  return _mm256_cvttpd_epi32(_mm256_sub_pd(truncated, below));
}

__attribute__((target("avx2"))) RowCounts ProjectRowAvx2(const RowProjection& p, int32_t* kx,
                                                         int32_t* ky, int32_t* kz, uint8_t* state) {
  RowCounts n;
  const __m256d scale = _mm256_set1_pd(p.scale);
  const __m256d lo = _mm256_set1_pd(p.min_depth), hi = _mm256_set1_pd(p.max_depth);
  int c = 0;
  for (; c + 4 <= p.cols; c += 4) {
    const __m256d d = _mm256_cvtepi32_pd(
        _mm_cvtepu16_epi32(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(p.depth + c))));
    const __m256d z = _mm256_mul_pd(d, scale);
    const __m256d valid = _mm256_cmp_pd(d, _mm256_setzero_pd(), _CMP_NEQ_OQ);
    const __m256d inside =
        _mm256_and_pd(_mm256_cmp_pd(z, lo, _CMP_GE_OQ), _mm256_cmp_pd(z, hi, _CMP_LE_OQ));
    const __m256d fx = AxisCoordinate(z, p.base_x, p.ray_x + c, p.tx, p.ox, p.inv_resolution);
    const __m256d fy = AxisCoordinate(z, p.base_y, p.ray_y + c, p.ty, p.oy, p.inv_resolution);
    const __m256d fz = AxisCoordinate(z, p.base_z, p.ray_z + c, p.tz, p.oz, p.inv_resolution);
    const __m256d keyed =
        _mm256_and_pd(_mm256_and_pd(InKeyRange(fx), InKeyRange(fy)), InKeyRange(fz));
    const __m256d observed = _mm256_and_pd(valid, inside);
    const __m256d use = _mm256_and_pd(observed, keyed);
    _mm_storeu_si128(reinterpret_cast<__m128i*>(kx + c), FloorKeys(fx, use));
    _mm_storeu_si128(reinterpret_cast<__m128i*>(ky + c), FloorKeys(fy, use));
    _mm_storeu_si128(reinterpret_cast<__m128i*>(kz + c), FloorKeys(fz, use));
    const int valid_bits = _mm256_movemask_pd(valid);
    const int observed_bits = _mm256_movemask_pd(observed);
    const int use_bits = _mm256_movemask_pd(use);
    const uint32_t states =
        kSpread[use_bits] * kRowUse + kSpread[observed_bits & ~use_bits] * kRowNoKey;
    std::memcpy(state + c, &states, sizeof states);
    n.in_range += std::popcount(static_cast<unsigned>(observed_bits));
    n.out_of_range += std::popcount(static_cast<unsigned>(valid_bits & ~observed_bits));
  }
  if (c < p.cols) {
    RowProjection tail = p;
    tail.depth += c, tail.ray_x += c, tail.ray_y += c, tail.ray_z += c, tail.cols -= c;
    const RowCounts t = ProjectRowScalar(tail, kx + c, ky + c, kz + c, state + c);
    n.in_range += t.in_range, n.out_of_range += t.out_of_range;
  }
  return n;
}

#endif  // SKIMAP_ROW_PROJECTION_AVX2

}  // namespace

RowCounts ProjectRowScalar(const RowProjection& p, int32_t* kx, int32_t* ky, int32_t* kz,
                           uint8_t* state) {
  RowCounts n;
  for (int c = 0; c < p.cols; ++c) {
    const uint16_t d = p.depth[c];
    const double z = d * p.scale;
    const bool valid = d != 0, observed = valid & (z >= p.min_depth) & (z <= p.max_depth);
    const double vx = z * (p.base_x + p.ray_x[c]) + p.tx;
    const double vy = z * (p.base_y + p.ray_y[c]) + p.ty;
    const double vz = z * (p.base_z + p.ray_z[c]) + p.tz;
    const double fx = (vx - p.ox) * p.inv_resolution;
    const double fy = (vy - p.oy) * p.inv_resolution;
    const double fz = (vz - p.oz) * p.inv_resolution;
    const bool keyed = (fx >= kLowest) & (fx < kPastHighest) & (fy >= kLowest) &
                       (fy < kPastHighest) & (fz >= kLowest) & (fz < kPastHighest);
    const bool use = observed & keyed;
    kx[c] = use ? FloorKey(fx) : 0;
    ky[c] = use ? FloorKey(fy) : 0;
    kz[c] = use ? FloorKey(fz) : 0;
    state[c] = use ? kRowUse : observed ? kRowNoKey : kRowSkip;
    n.in_range += observed;
    n.out_of_range += valid & !observed;
  }
  return n;
}

RowCounts ProjectRow(const RowProjection& p, int32_t* kx, int32_t* ky, int32_t* kz,
                     uint8_t* state) {
#ifdef SKIMAP_ROW_PROJECTION_AVX2
  static const bool avx2 = __builtin_cpu_supports("avx2");
  if (avx2) return ProjectRowAvx2(p, kx, ky, kz, state);
#endif
  return ProjectRowScalar(p, kx, ky, kz, state);
}

}  // namespace skimap::perception
