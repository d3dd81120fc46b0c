#include "perception/frame_integrator.h"

#include <cmath>
#include <cstdlib>
#include <vector>

#include "perception/row_projection.h"

namespace skimap::perception {

absl::Status ValidateIntegrationOptions(const IntegrationOptions& o) {
  if (!(o.min_depth >= 0) || !std::isfinite(o.min_depth)) {
    return absl::InvalidArgumentError("min_depth must be finite and >= 0");
  }
  if (!(o.max_depth > o.min_depth) || !std::isfinite(o.max_depth)) {
    return absl::InvalidArgumentError("max_depth must be finite and > min_depth");
  }
  if (o.pixel_stride < 1 || o.pixel_stride > 64) {
    return absl::InvalidArgumentError("pixel_stride must be in 1..64");
  }
  if (!(o.depth_edge_jump >= 0 && o.depth_edge_jump <= 1)) {
    return absl::InvalidArgumentError("depth_edge_jump must be in [0, 1]");
  }
  return absl::OkStatus();
}

IntegrationStats BuildFrameBatch(const RgbdFrame& frame, const Grid& grid,
                                 const IntegrationOptions& options,
                                 VoxelBatch<RGBWeightedVoxel>* batch, ThreadPool* pool) {
  batch->Clear();
  IntegrationStats stats;
  const PinholeCamera& cam = frame.camera;
  const int stride = options.pixel_stride;
  const int cols = (cam.width + stride - 1) / stride, rows = (cam.height + stride - 1) / stride;
  const Eigen::Matrix3d rot = frame.pose.rotation.toRotationMatrix();
  const Eigen::Vector3d t = frame.pose.translation;
  // World direction of pixel (u, v) at unit depth = row_base[v] + col_term[u], the column
  // terms stored per axis so that the row loop below reads them as arrays. Kept per thread:
  // no allocation per frame once they have grown.
  thread_local std::vector<double> col_x, col_y, col_z;
  thread_local std::vector<Eigen::Vector3d> row_base;
  col_x.resize(cols), col_y.resize(cols), col_z.resize(cols), row_base.resize(rows);
  for (int c = 0; c < cols; ++c) {
    const Eigen::Vector3d term = rot.col(0) * ((c * stride - cam.cx) / cam.fx);
    col_x[c] = term.x(), col_y[c] = term.y(), col_z[c] = term.z();
  }
  for (int r = 0; r < rows; ++r) {
    row_base[r] = rot * Eigen::Vector3d(0, (r * stride - cam.cy) / cam.fy, 1);
  }
  const uint16_t* depth = frame.depth.pixels.data();
  const uint8_t* rgb = frame.color ? frame.color->rgb.data() : nullptr;
  const Eigen::Vector3d* bases = row_base.data();
  // Per row: pixels with depth in range, and with valid depth outside it (each row is
  // filled by one thread; summed below).
  thread_local std::vector<uint32_t> row_in, row_out, row_edges;
  row_in.assign(rows, 0), row_out.assign(rows, 0), row_edges.assign(rows, 0);
  // (Pointers: the pool's threads must write this thread's arrays, not their own.)
  uint32_t* const in_rows = row_in.data();
  uint32_t* const out_rows = row_out.data();
  uint32_t* const edge_rows = row_edges.data();
  const double jump = options.depth_edge_jump;
  // One row: ProjectRow (perception/row_projection.h) computes its keys, the same as
  // Grid::ToKey's, 4 pixels at a time where the CPU has AVX2; strided rows are gathered
  // into a contiguous row first. `shared` is what every row has in common; each row sets
  // its pixels and its base term.
  RowProjection shared{};
  shared.cols = cols;
  shared.scale = frame.depth_scale;
  shared.min_depth = options.min_depth, shared.max_depth = options.max_depth;
  shared.ray_x = col_x.data(), shared.ray_y = col_y.data(), shared.ray_z = col_z.data();
  shared.tx = t.x(), shared.ty = t.y(), shared.tz = t.z();
  shared.ox = grid.origin().x, shared.oy = grid.origin().y, shared.oz = grid.origin().z;
  shared.inv_resolution = grid.inv_resolution();
  using Batch = VoxelBatch<RGBWeightedVoxel>;
  static_assert(Batch::kUse == kRowUse && Batch::kNoKey == kRowNoKey && Batch::kSkip == kRowSkip);
  auto fill_row = [&, shared, in_rows, out_rows, edge_rows](size_t r, Batch::KeyRow keys,
                                                            RGBWeightedVoxel* obs) {
    const size_t first = r * stride * cam.width;
    const uint16_t* row = depth + first;
    if (jump > 0) {
      // The row without its flying pixels: d is dropped when a 4-neighbour d' != 0 has
      // |d - d'| > jump * d.
      thread_local std::vector<uint16_t> kept;
      kept.resize(cols);
      const int v = int(r) * stride;
      const uint16_t* up = v > 0 ? row - cam.width : nullptr;
      const uint16_t* down = v + 1 < cam.height ? row + cam.width : nullptr;
      uint32_t edges = 0;
      if (stride == 1) {
        // The same test without branches, so that it runs on vector lanes: |d - d'| is an
        // integer, so |d - d'| > jump * d exactly when |d - d'| > floor(jump * d); a missing
        // neighbour (the image border) is the pixel itself, which is never far.
        thread_local std::vector<int32_t> limit;
        limit.resize(cols);
        for (int c = 0; c < cols; ++c) limit[c] = static_cast<int32_t>(jump * row[c]);
        const uint16_t* above = up != nullptr ? up : row;
        const uint16_t* below = down != nullptr ? down : row;
        auto far = [](int32_t d, int32_t n, int32_t t) {
          return static_cast<uint32_t>(n != 0) & static_cast<uint32_t>(std::abs(d - n) > t);
        };
        auto keep = [&](int c, int32_t left, int32_t right) {
          const int32_t d = row[c], t = limit[c];
          const uint32_t edge =
              static_cast<uint32_t>(d != 0) &
              (far(d, left, t) | far(d, right, t) | far(d, above[c], t) | far(d, below[c], t));
          kept[c] = static_cast<uint16_t>(d * static_cast<int32_t>(1 - edge));
          return edge;
        };
        edges += keep(0, row[0], cols > 1 ? row[1] : row[0]);
        for (int c = 1; c + 1 < cols; ++c) edges += keep(c, row[c - 1], row[c + 1]);
        if (cols > 1) edges += keep(cols - 1, row[cols - 2], row[cols - 1]);
      } else {
        for (int c = 0; c < cols; ++c) {
          const int u = c * stride;
          const int d = row[u];
          const double limit = jump * d;
          auto far = [&](int n) { return n != 0 && std::abs(d - n) > limit; };
          const bool edge =
              d != 0 && ((u > 0 && far(row[u - 1])) || (u + 1 < cam.width && far(row[u + 1])) ||
                         (up != nullptr && far(up[u])) || (down != nullptr && far(down[u])));
          kept[c] = edge ? 0 : uint16_t(d);
          edges += edge;
        }
      }
      edge_rows[r] = edges;
      row = kept.data();
    } else if (stride > 1) {
      thread_local std::vector<uint16_t> gathered;
      gathered.resize(cols);
      for (int c = 0; c < cols; ++c) gathered[c] = row[size_t(c) * stride];
      row = gathered.data();
    }
    RowProjection projection = shared;
    projection.depth = row;
    projection.base_x = bases[r].x(), projection.base_y = bases[r].y();
    projection.base_z = bases[r].z();
    const RowCounts counts = ProjectRow(projection, keys.x, keys.y, keys.z, keys.state);
    in_rows[r] = counts.in_range, out_rows[r] = counts.out_of_range;
    if (rgb != nullptr) {
      const uint8_t* px = rgb + 3 * first;
      for (int c = 0; c < cols; ++c) {
        const uint8_t* p = px + 3 * size_t(c) * stride;
        obs[c] = RGBWeightedVoxel(p[0], p[1], p[2], 1.0f);
      }
    } else {
      for (int c = 0; c < cols; ++c) obs[c] = RGBWeightedVoxel(128, 128, 128, 1.0f);
    }
  };
  batch->AddRows(size_t(rows), size_t(cols), fill_row, pool);
  size_t in_range = 0;
  for (int r = 0; r < rows; ++r) {
    in_range += row_in[r], stats.out_of_range += row_out[r], stats.depth_edges += row_edges[r];
  }
  stats.no_key = batch->rejected();
  stats.points = in_range - stats.no_key;
  batch->Finalize(pool);
  return stats;
}

}  // namespace skimap::perception
