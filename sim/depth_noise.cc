// Depth and colour sensor noise. See depth_noise.h for the model.
#include "sim/depth_noise.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace skimap::sim {
namespace {

// Fast deterministic uniform [0, 1) from the 64-bit stream.
inline float UnitUniform(std::mt19937_64& rng) {
  return static_cast<float>(rng() >> 40) * (1.0f / 16777216.0f);
}

// 65536 standard-normal samples (inverse CDF at stratified points, so the table is exact
// and identical on every host), indexed by 16 random bits: far cheaper than Box-Muller.
const std::vector<float>& NormalTable() {
  static const std::vector<float> table = [] {
    std::vector<float> t(65536);
    for (int i = 0; i < 65536; ++i) {
      // Acklam-free approach: bisection on erf for the (i + 0.5) / 65536 quantile.
      const double p = (i + 0.5) / 65536.0;
      double lo = -6, hi = 6;
      for (int it = 0; it < 60; ++it) {
        const double mid = 0.5 * (lo + hi);
        (0.5 * std::erfc(-mid / std::sqrt(2.0)) < p ? lo : hi) = mid;
      }
      t[i] = static_cast<float>(0.5 * (lo + hi));
    }
    return t;
  }();
  return table;
}

inline float Normal(std::mt19937_64& rng) { return NormalTable()[rng() >> 48]; }

}  // namespace

cv::Mat SimulateDepth(const cv::Mat& ideal, const cv::Mat& incidence, float fx, double depth_scale,
                      const DepthNoise& noise, std::mt19937_64& rng) {
  cv::Mat out(ideal.size(), CV_16UC1, cv::Scalar(0));
  const float to_units = static_cast<float>(1000.0 / depth_scale);
  const float bf = noise.baseline * fx;
  for (int y = 0; y < ideal.rows; ++y) {
    const float* z_row = ideal.ptr<float>(y);
    const float* c_row = incidence.ptr<float>(y);
    uint16_t* o = out.ptr<uint16_t>(y);
    for (int x = 0; x < ideal.cols; ++x) {
      float z = z_row[x];
      if (z < noise.min_range || z > noise.max_range) continue;
      if (noise.enabled) {
        if (c_row[x] < noise.grazing_cos && UnitUniform(rng) < noise.grazing_drop) continue;
        float jump = 0, nearest = z, farthest = z;  // over the neighbours with depth
        for (int dy = -1; dy <= 1; ++dy) {
          const int yy = std::clamp(y + dy, 0, ideal.rows - 1);
          const float* r = ideal.ptr<float>(yy);
          for (int dx = -1; dx <= 1; ++dx) {
            const float n = r[std::clamp(x + dx, 0, ideal.cols - 1)];
            jump = std::max(jump, n == 0 ? 1.f : std::abs(n - z));
            if (n != 0) nearest = std::min(nearest, n), farthest = std::max(farthest, n);
          }
        }
        if (jump > noise.edge_jump) {
          if (UnitUniform(rng) < noise.edge_drop) continue;
          if (noise.edge_mix > 0 && UnitUniform(rng) < noise.edge_mix) {
            z = nearest + UnitUniform(rng) * (farthest - nearest);
          }
        }
        if (UnitUniform(rng) < noise.random_drop) continue;
        const float d = z - 0.4f;
        z += Normal(rng) * (noise.axial_a + noise.axial_b * d * d);
        if (noise.subpixel > 0) {
          const float disparity = std::round(bf / z * noise.subpixel) / noise.subpixel;
          if (disparity <= 0) continue;
          z = bf / disparity;
        }
      }
      const float v = std::round(z * to_units);
      o[x] = static_cast<uint16_t>(std::clamp(v, 0.f, 65535.f));
    }
  }
  return out;
}

void AddColourNoise(cv::Mat& bgr, float sigma, std::mt19937_64& rng) {
  if (sigma <= 0) return;
  const std::vector<float>& table = NormalTable();
  for (int y = 0; y < bgr.rows; ++y) {
    uint8_t* p = bgr.ptr<uint8_t>(y);
    const int n = bgr.cols * 3;
    for (int i = 0; i < n; i += 4) {
      uint64_t bits = rng();  // four 16-bit table indices per draw
      for (int k = 0; k < 4 && i + k < n; ++k, bits >>= 16) {
        const float v = p[i + k] + sigma * table[bits & 0xffff];
        p[i + k] = static_cast<uint8_t>(std::clamp(v + 0.5f, 0.f, 255.f));
      }
    }
  }
}

}  // namespace skimap::sim
