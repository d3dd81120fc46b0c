#include "server/core/maps/grid_views.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <utility>

namespace skimap::server {

GridViews::View GridViews::MakeView(uint64_t sequence, const perception::RgbdFrame& frame) {
  View v;
  v.sequence = sequence;
  v.depth_scale = float(frame.depth_scale);
  perception::HalfResolution(frame.depth, frame.camera, &v.depth, &v.camera);
  v.world_from_camera = perception::ToIsometry(frame.pose);
  v.camera_from_world = v.world_from_camera.inverse().cast<float>();
  return v;
}

void GridViews::Offer(View view) {
  if (options_.capacity == 0) return;
  const double min_angle = options_.min_angle_deg * std::numbers::pi / 180;
  for (auto it = views_.begin(); it != views_.end(); ++it) {
    const double distance =
        (it->world_from_camera.translation() - view.world_from_camera.translation()).norm();
    if (distance >= options_.min_distance) continue;
    const double angle = Eigen::AngleAxisd(it->world_from_camera.linear().transpose() *
                                           view.world_from_camera.linear())
                             .angle();
    if (angle < min_angle) {
      views_.erase(it);
      break;
    }
  }
  if (views_.size() >= options_.capacity) views_.pop_front();
  views_.push_back(std::move(view));
}

void GridViews::Move(uint64_t sequence, const Eigen::Isometry3d& world_from_camera) {
  for (View& v : views_) {
    if (v.sequence == sequence) {
      v.world_from_camera = world_from_camera;
      v.camera_from_world = world_from_camera.inverse().cast<float>();
      return;
    }
  }
}

GridViews::Verdict GridViews::Decide(const Eigen::Vector3f& p, float edge) const {
  for (auto it = views_.rbegin(); it != views_.rend(); ++it) {
    const Verdict v = DecideIn(*it, p, edge);
    if (v != Verdict::kUndecided) return v;
  }
  return Verdict::kUndecided;
}

GridViews::Verdict GridViews::DecideIn(const View& view, const Eigen::Vector3f& p,
                                       float edge) const {
  const Eigen::Vector3f c = view.camera_from_world * p;
  const float z = c.z();
  const float half_diagonal = 0.87f * edge;
  if (!(z - half_diagonal >= float(options_.min_depth))) return Verdict::kUndecided;
  const float fx = float(view.camera.fx), fy = float(view.camera.fy);
  const float cx = float(view.camera.cx), cy = float(view.camera.cy);
  const float u = fx * c.x() / z + cx, v = fy * c.y() / z + cy;
  // The kept pixels around the cube's projection (inside a circle of radius
  // f * half_diagonal / (z - half_diagonal)), at most 9 per axis.
  const float reach = half_diagonal / (z - half_diagonal);
  const int u0 = int(std::floor(u - fx * reach)), u1 = int(std::ceil(u + fx * reach));
  const int v0 = int(std::floor(v - fy * reach)), v1 = int(std::ceil(v + fy * reach));
  if (u0 < 0 || v0 < 0 || u1 >= view.depth.width || v1 >= view.depth.height) {
    return Verdict::kUndecided;
  }
  const int step_u = std::max(1, (u1 - u0 + 8) / 9), step_v = std::max(1, (v1 - v0 + 8) / 9);
  // Rays in the world: origin o, direction R (x, y, 1) so that the parameter is the depth
  // along the optical axis, as the depth image measures it.
  const Eigen::Matrix3f r = view.camera_from_world.linear().transpose();
  const Eigen::Vector3f o = view.world_from_camera.translation().cast<float>();
  const Eigen::Vector3f lo = p.array() - edge / 2, hi = p.array() + edge / 2;
  bool through = false, blocked = false;
  for (int py = v0; py <= v1; py += step_v) {
    const uint16_t* row = view.depth.pixels.data() + size_t(py) * size_t(view.depth.width);
    for (int px = u0; px <= u1; px += step_u) {
      const Eigen::Vector3f dir =
          r * Eigen::Vector3f((float(px) - cx) / fx, (float(py) - cy) / fy, 1);
      float t_in = 0, t_out = std::numeric_limits<float>::infinity();
      for (int a = 0; a < 3; ++a) {
        if (std::abs(dir[a]) < 1e-9f) {
          if (o[a] < lo[a] || o[a] > hi[a]) t_out = -1;
          continue;
        }
        float ta = (lo[a] - o[a]) / dir[a], tb = (hi[a] - o[a]) / dir[a];
        if (ta > tb) std::swap(ta, tb);
        t_in = std::max(t_in, ta);
        t_out = std::min(t_out, tb);
      }
      if (!(t_in < t_out)) continue;  // this pixel's ray misses the voxel
      const uint16_t raw = row[px];
      if (raw == 0) {  // unmeasured: no evidence either way
        blocked = true;
        continue;
      }
      const float d = float(raw) * view.depth_scale;
      const float beyond = std::max(0.0f, d - 0.4f);
      const float noise = 3 * (0.0012f + 0.0019f * beyond * beyond);
      if (d < t_in - noise) {
        blocked = true;  // something in front of the voxel
      } else if (d <= t_out + noise) {
        return Verdict::kSeen;  // a surface inside it
      } else {
        through = true;
      }
    }
  }
  return through && !blocked ? Verdict::kSeenThrough : Verdict::kUndecided;
}

void ClearSeenThroughCells(const SkiMap<RGBWeightedVoxel>& rgb,
                           const skimap::internal::OccupancyBands& b, const GridViews& views,
                           OccupancyGrid* grid, ThreadPool* pool) {
  if (views.size() == 0) return;
  const RasterGeometry& g = grid->geometry;
  const Grid& voxels = rgb.grid();
  const float edge = float(voxels.resolution());
  // One occupied column's cell: its band voxels tested lowest first, the first not seen
  // through keeps it occupied (most columns stop at their first voxel).
  auto column_cell = [&](int32_t kx, int32_t ky, const auto& column) {
    bool floor = false, obstacle = false;
    column.ForEachInRangeWhile(b.floor0, b.band1, [&](int32_t kz, const RGBWeightedVoxel& v) {
      if (v.Weight() < b.min_weight) return true;
      if (kz <= b.floor1) {
        floor = true;
        return true;
      }
      if (kz < b.band0) return true;
      const Point3 centre = voxels.Center(VoxelKey{kx, ky, kz});
      const Eigen::Vector3f p(float(centre.x), float(centre.y), float(centre.z));
      obstacle = views.Decide(p, edge) != GridViews::Verdict::kSeenThrough;
      return !obstacle;
    });
    return obstacle ? OccupancyGrid::kOccupied
           : floor  ? OccupancyGrid::kFree
                    : OccupancyGrid::kUnknown;
  };
  // Rows of cells; each run of occupied cells along x is one walk of the map's columns.
  auto rows = [&](size_t first, size_t last) {
    for (size_t j = first; j < last; ++j) {
      int8_t* row = grid->cells.data() + j * size_t(g.width);
      const int32_t ky = g.key_y0 + int32_t(j);
      for (int32_t i = 0; i < g.width;) {
        if (row[i] != OccupancyGrid::kOccupied) {
          ++i;
          continue;
        }
        int32_t end = i;
        while (end < g.width && row[end] == OccupancyGrid::kOccupied) ++end;
        rgb.ForEachColumn(g.key_x0 + i, g.key_x0 + end - 1, ky, ky,
                          [&](int32_t kx, int32_t, const auto& column) {
                            row[kx - g.key_x0] = column_cell(kx, ky, column);
                          });
        i = end;
      }
    }
  };
  if (pool == nullptr || pool->workers() == 0 || g.height < 64) {
    rows(0, size_t(g.height));
  } else {
    pool->ParallelFor(size_t(g.height), rows);
  }
}

}  // namespace skimap::server
