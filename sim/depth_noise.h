// Structured-light depth sensor model (Kinect v1 / Asus Xtion class), applied to the ideal
// depth of rasterizer.h, plus colour sensor noise.
//
// Depth, in this order, per pixel with ideal depth z (metres):
//   1. out of range: z < min_range or z > max_range -> 0 (no depth)
//   2. grazing angles: |cos(incidence)| < grazing_cos -> 0 with probability grazing_drop
//   3. object edges: a depth jump > edge_jump within the 3x3 neighbourhood -> 0 with
//      probability edge_drop (the shadow band of real sensors); an edge pixel that is kept
//      becomes, with probability edge_mix, a mixed ("flying") pixel: a depth drawn
//      uniformly between the nearest and the farthest depth of its neighbourhood, as
//      time-of-flight sensors return where one pixel sees foreground and background
//   4. random dropouts with probability random_drop
//   5. axial noise: z += N(0, sigma(z)), sigma = axial_a + axial_b * (z - 0.4)^2
//      (Nguyen, Izadi, Lovell 2012: 0.0012 + 0.0019 (z - 0.4)^2)
//   6. disparity quantisation: d = baseline * fx / z rounded to 1/subpixel px, z = b fx / d
//      (subpixel 0: none, a time-of-flight sensor)
// then stored as uint16 round(z * 1000 / depth_scale).
//
// Thread safety: pure functions; the random stream is the caller's.
#ifndef SKIMAP_SIM_DEPTH_NOISE_H_
#define SKIMAP_SIM_DEPTH_NOISE_H_

#include <cstdint>
#include <opencv2/core.hpp>
#include <random>

namespace skimap::sim {

// Parameters of the depth sensor model; defaults model a Kinect v1.
struct DepthNoise {
  bool enabled = true;                        // false: only range limits and conversion to uint16
  float min_range = 0.45f, max_range = 4.5f;  // metres
  float grazing_cos = 0.18f, grazing_drop = 0.8f;
  float edge_jump = 0.05f, edge_drop = 0.6f;  // metres, probability
  float edge_mix = 0;                         // probability, of the edge pixels kept
  float random_drop = 0.003f;
  float axial_a = 0.0012f, axial_b = 0.0019f;  // metres, 1/metre
  float baseline = 0.075f;                     // metres
  float subpixel = 8;                          // disparity steps per pixel; 0: no disparity
};

// Converts ideal depth (CV_32FC1 metres) to a sensor depth image (CV_16UC1,
// value * depth_scale = mm). incidence: CV_32FC1 |cos| (rasterizer.h). fx in pixels.
cv::Mat SimulateDepth(const cv::Mat& ideal, const cv::Mat& incidence, float fx, double depth_scale,
                      const DepthNoise& noise, std::mt19937_64& rng);

// Adds zero-mean Gaussian noise of `sigma` grey levels to a CV_8UC3 image, in place.
void AddColourNoise(cv::Mat& bgr, float sigma, std::mt19937_64& rng);

}  // namespace skimap::sim

#endif  // SKIMAP_SIM_DEPTH_NOISE_H_
