#include "server/core/maps/grid_inflation.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

namespace skimap::server {

void InflateObstacles(double radius_cells, OccupancyGrid* grid) {
  const int w = grid->geometry.width, h = grid->geometry.height;
  if (w == 0 || h == 0) return;
  // Distance to the nearest zero pixel: occupied cells are the zeros.
  cv::Mat mask(h, w, CV_8U);
  bool any = false;
  for (int j = 0; j < h; ++j) {
    for (int i = 0; i < w; ++i) {
      const bool occupied = grid->cells[size_t(j) * w + i] == OccupancyGrid::kOccupied;
      mask.at<uint8_t>(j, i) = occupied ? 0 : 255;
      any = any || occupied;
    }
  }
  if (!any) return;
  // A radius of a whole number of cells in metres (0.3 m at 5 cm) divides to just below it.
  const double r = radius_cells + 1e-9;
  cv::Mat distance;
  cv::distanceTransform(mask, distance, cv::DIST_L2, cv::DIST_MASK_PRECISE, CV_32F);
  for (int j = 0; j < h; ++j) {
    for (int i = 0; i < w; ++i) {
      int8_t& cell = grid->cells[size_t(j) * w + i];
      const double d = distance.at<float>(j, i);
      if (cell != OccupancyGrid::kFree || d > r) continue;
      // d >= 1 for a free cell: 99 beside the obstacle, 1 at the radius.
      const double t = r > 1 ? (r - d) / (r - 1) : 1.0;
      cell = int8_t(std::clamp<long>(1 + std::lround(98 * t), 1, 99));
    }
  }
}

}  // namespace skimap::server
