#include "perception/free_space.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <numbers>
#include <optional>
#include <span>
#include <vector>

#include "perception/free_space_fan.h"

namespace skimap::perception {
namespace {

using internal::Fan;
using internal::FanRay;
using internal::FastAtan2;
using internal::Interval;
using internal::kPi;
using internal::MakeFan;
using internal::Wrap;

// Splits [0, n) into `pieces` contiguous ranges and runs fn(piece, begin, end) for each, on
// the pool's threads when there is one.
template <class Fn>
void ForPieces(ThreadPool* pool, size_t n, size_t pieces, Fn&& fn) {
  auto run = [&](size_t first, size_t last) {
    for (size_t p = first; p < last; ++p) fn(p, n * p / pieces, n * (p + 1) / pieces);
  };
  if (pool == nullptr || pool->workers() == 0 || pieces == 1) {
    run(0, pieces);
  } else {
    pool->ParallelFor(pieces, run);
  }
}

}  // namespace

absl::Status ValidateFreeSpaceOptions(const FreeSpaceOptions& o) {
  if (o.pixel_stride < 1 || o.pixel_stride > 64) {
    return absl::InvalidArgumentError("carve_pixel_stride must be in 1..64");
  }
  if (!std::isfinite(o.min_z) || !std::isfinite(o.max_z) || !(o.min_z <= o.max_z)) {
    return absl::InvalidArgumentError("band: carving needs finite min_z <= max_z");
  }
  return absl::OkStatus();
}

FreeSpaceStats BuildFreeSpaceBatch(const RgbdFrame& frame, const Grid& grid,
                                   const IntegrationOptions& integration,
                                   const FreeSpaceOptions& options,
                                   VoxelBatch<FreeColumnsVoxel>* batch, ThreadPool* pool) {
  batch->Clear();
  FreeSpaceStats stats;
  const PinholeCamera& cam = frame.camera;
  const int stride = options.pixel_stride;
  const Eigen::Matrix3d rot = frame.pose.rotation.toRotationMatrix();
  const Eigen::Vector3d& o = frame.pose.translation;
  const double res = grid.resolution();
  const uint16_t* depth = frame.depth.pixels.data();
  // Pieces of work (x ranges of blocks), concatenated in order: the batch does not depend
  // on the pool. The pool only takes a fan whose key box holds at least kPoolMinCells
  // columns: the rays (at most 19 200 at stride 4) and a small fan take less time than its
  // rounds cost on a 2-core machine (docs/benchmarks.md, "Free space").
  constexpr int64_t kPoolMinCells = int64_t{1} << 16;
  const size_t pieces = pool == nullptr ? 1 : 4 * size_t(pool->workers() + 1);
  // Angles are measured from the optical axis's azimuth (any azimuth when it looks
  // straight down), so a camera's fan does not straddle the +-pi seam unless its rays point
  // all around it (a camera looking down past the nadir): bins across the seam are not
  // joined, and the rays of the bins beside it cover it (FreeSpaceTest, straight down).
  const Eigen::Vector3d axis = rot.col(2);
  const double reference =
      std::hypot(axis.x(), axis.y()) > 1e-9 ? std::atan2(axis.y(), axis.x()) : 0.0;
  // Pass 1: every ray's slab part as a fan ray. The ray through pixel (u, v) is
  // base + du * u + dv * v in the world (not normalised).
  const Eigen::Vector3d du = rot.col(0) / cam.fx, dv = rot.col(1) / cam.fy;
  const Eigen::Vector3d base = rot.col(2) - du * cam.cx - dv * cam.cy;
  std::vector<FanRay> rays;
  rays.reserve(size_t((cam.height + stride - 1) / stride) *
               size_t((cam.width + stride - 1) / stride));
  bool from_camera = true;    // every ray's slab part starts at the camera
  bool under_camera = false;  // a ray's slab part stays in the camera's own column
  for (int v = 0; v < cam.height; v += stride) {
    const double yv = (v - cam.cy) / cam.fy;
    const Eigen::Vector3d row = base + dv * v;
    for (int u = 0; u < cam.width; u += stride) {
      const uint16_t d = depth[size_t(v) * cam.width + u];
      if (d == 0) continue;
      const double z = d * frame.depth_scale;
      if (z < integration.min_depth || z > integration.max_depth) continue;
      const double xu = (u - cam.cx) / cam.fx;
      const double length = z * std::sqrt(xu * xu + yv * yv + 1);
      if (length <= res) continue;
      // From the camera to one voxel short of the hit, clipped to the slab.
      const Eigen::Vector3d hit = (row + du * u) * (z * (length - res) / length);
      double t0 = 0, t1 = 1;
      if (std::abs(hit.z()) < 1e-12) {
        if (o.z() < options.min_z || o.z() > options.max_z) continue;
      } else {
        double ta = (options.min_z - o.z()) / hit.z(), tb = (options.max_z - o.z()) / hit.z();
        if (ta > tb) std::swap(ta, tb);
        t0 = std::max(t0, ta);
        t1 = std::min(t1, tb);
        if (!(t0 < t1)) continue;
      }
      ++stats.rays;
      const double h = std::sqrt(hit.x() * hit.x() + hit.y() * hit.y());
      if (t1 * h < 0.5 * res) {
        under_camera = true;
        continue;
      }
      from_camera = from_camera && t0 == 0;
      rays.push_back({Wrap(FastAtan2(hit.y(), hit.x()) - reference), t0 * h, t1 * h});
    }
  }
  // The camera's own column is crossed when a ray starts there.
  int32_t camera_x = 0, camera_y = 0;
  const bool camera_keyed = grid.AxisToKey(o.x(), grid.origin().x, &camera_x) &&
                            grid.AxisToKey(o.y(), grid.origin().y, &camera_y);
  const bool mark_camera =
      camera_keyed && (under_camera || std::any_of(rays.begin(), rays.end(),
                                                   [](const FanRay& r) { return r.r0 == 0; }));
  using Item = VoxelBatch<FreeColumnsVoxel>::Item;
  constexpr int32_t kSide = FreeColumnsVoxel::kSide;
  std::vector<std::vector<Item>> item_pieces(pieces);
  if (!rays.empty()) {
    const Fan fan = MakeFan(rays, res, 2.5 * stride / std::min(cam.fx, cam.fy), from_camera);
    // Pass 2: the key box of the fan (its intervals' ends at both edges of their bins).
    double lo_x = o.x(), hi_x = o.x(), lo_y = o.y(), hi_y = o.y();
    for (size_t b = 0; b < fan.bins(); ++b) {
      for (const Interval& r : fan.Of(b)) {
        for (double edge : {0.0, 1.0}) {
          const double angle = reference + fan.min_angle + (double(b) + edge) * fan.bin_width;
          const double cx = std::cos(angle), cy = std::sin(angle);
          for (double radius : {r.r0, r.r1}) {
            lo_x = std::min(lo_x, o.x() + radius * cx), hi_x = std::max(hi_x, o.x() + radius * cx);
            lo_y = std::min(lo_y, o.y() + radius * cy), hi_y = std::max(hi_y, o.y() + radius * cy);
          }
        }
      }
    }
    int32_t min_x, min_y, max_x, max_y;
    if (grid.AxisToKey(lo_x - res, grid.origin().x, &min_x) &&
        grid.AxisToKey(lo_y - res, grid.origin().y, &min_y) &&
        grid.AxisToKey(hi_x + res, grid.origin().x, &max_x) &&
        grid.AxisToKey(hi_y + res, grid.origin().y, &max_y)) {
      // Pass 3: every column whose centre lies in the fan, a stripe of kSide x keys (one
      // block column) at a time, its blocks emitted in y order (so the keys are sorted). A
      // fan that leaves the key range carves nothing.
      const double max_r2 = fan.max_r * fan.max_r;
      const size_t bins = fan.bins();
      const int32_t block_x0 = FreeColumnsVoxel::BlockKey(min_x, 0).x;
      const size_t stripes = size_t((int64_t{max_x} - block_x0) / kSide + 1);
      // A fan narrower than a half-turn lies in a convex wedge from the camera: its edges
      // (a bin wider on each side, for rounding) bound each column's ys, so only cells the
      // wedge can hold are tested. A wider fan is bounded by its reach only.
      const double a1 = reference + fan.min_angle - fan.bin_width;
      const double a2 = reference + fan.min_angle + double(bins + 1) * fan.bin_width;
      const bool wedge = a2 - a1 < kPi - 0.01;
      const double d1x = std::cos(a1), d1y = std::sin(a1), d2x = std::cos(a2), d2y = std::sin(a2);
      // The intervals' squared radii: cells compare their squared distance (no root).
      std::vector<Interval> squared(fan.intervals.size());
      for (size_t i = 0; i < squared.size(); ++i) {
        squared[i] = {fan.intervals[i].r0 * fan.intervals[i].r0,
                      fan.intervals[i].r1 * fan.intervals[i].r1};
      }
      // Whether the cell centre (dx, dy) from the camera lies in the fan.
      auto in_fan = [&](double dx, double dy) {
        const double r2 = dx * dx + dy * dy;
        if (r2 > max_r2) return false;
        const double a = Wrap(FastAtan2(dy, dx) - reference) - fan.min_angle;
        if (a < 0) return false;
        const size_t b = size_t(a / fan.bin_width);
        if (b >= bins) return false;
        for (uint32_t j = fan.first[b]; j < fan.first[b + 1]; ++j) {
          if (r2 >= squared[j].r0 && r2 <= squared[j].r1) return true;
        }
        return false;
      };
      // A block's cell centres (x in [cx0, cx1], y in [cy0, cy1] from the camera) all in the
      // fan, none, or some. Away from the camera the centres' angles lie between those of
      // the rectangle's corners (a convex set without the camera), and their distances
      // between the rectangle's nearest point and farthest corner: when every bin of that
      // angle range has one interval holding those distances, every centre is in the fan;
      // when none overlaps them, none is. The angle range gets a margin of 3e-5 rad for
      // FastAtan2's error at the corners and at the centres.
      enum class Cover { kAll, kNone, kSome };
      auto cover = [&](double cx0, double cx1, double cy0, double cy1) {
        if (cx0 <= res && cx1 >= -res && cy0 <= res && cy1 >= -res) return Cover::kSome;
        const double nx = std::clamp(0.0, cx0, cx1), ny = std::clamp(0.0, cy0, cy1);
        const double r2_min = nx * nx + ny * ny;
        if (r2_min > max_r2) return Cover::kNone;
        double r2_max = 0, a_min = 1e9, a_max = -1e9;
        for (double cx : {cx0, cx1}) {
          for (double cy : {cy0, cy1}) {
            r2_max = std::max(r2_max, cx * cx + cy * cy);
            const double a = Wrap(FastAtan2(cy, cx) - reference) - fan.min_angle;
            a_min = std::min(a_min, a);
            a_max = std::max(a_max, a);
          }
        }
        if (a_max - a_min > 1.0) return Cover::kSome;  // across the seam behind the camera
        constexpr double kMargin = 3e-5;
        const double lo = std::floor((a_min - kMargin) / fan.bin_width);
        const double hi = std::floor((a_max + kMargin) / fan.bin_width);
        if (hi < 0 || lo >= double(bins)) return Cover::kNone;
        bool all = lo >= 0 && hi < double(bins), any = false;
        for (size_t b = size_t(std::max(lo, 0.0)); b <= size_t(std::min(hi, double(bins - 1)));
             ++b) {
          bool holds = false;
          for (uint32_t j = fan.first[b]; j < fan.first[b + 1]; ++j) {
            holds = holds || (squared[j].r0 <= r2_min && squared[j].r1 >= r2_max);
            any = any || (squared[j].r0 <= r2_max && squared[j].r1 >= r2_min);
          }
          all = all && holds;
          if (!all && any) return Cover::kSome;
        }
        return all ? Cover::kAll : any ? Cover::kSome : Cover::kNone;
      };
      const bool big = (int64_t{max_x} - min_x + 1) * (int64_t{max_y} - min_y + 1) >= kPoolMinCells;
      ForPieces(
          big ? pool : nullptr, stripes, pieces, [&](size_t piece, size_t first, size_t last) {
            std::vector<Item>& out = item_pieces[piece];
            for (size_t stripe = first; stripe < last; ++stripe) {
              const int32_t bx = block_x0 + int32_t(stripe) * kSide;
              const int32_t x0 = std::max(bx, min_x), x1 = std::min(bx + kSide - 1, max_x);
              // Each column's candidate ys (empty: y0 > y1).
              std::array<int32_t, kSide> ys0, ys1;
              int32_t lo_y = max_y + 1, hi_y = min_y - 1;
              for (int32_t kx = x0; kx <= x1; ++kx) {
                int32_t& y0 = ys0[size_t(kx - bx)];
                int32_t& y1 = ys1[size_t(kx - bx)];
                y0 = 1, y1 = 0;
                const double dx = grid.AxisCenter(kx, grid.origin().x) - o.x();
                if (dx * dx > max_r2) continue;
                // Only the ys within max_r of the camera (a cell more at each end for rounding).
                const double reach = std::sqrt(max_r2 - dx * dx);
                y0 = min_y, y1 = max_y;
                if (int32_t k; grid.AxisToKey(o.y() - reach, grid.origin().y, &k)) {
                  y0 = std::max(y0, k - 1);
                }
                if (int32_t k; grid.AxisToKey(o.y() + reach, grid.origin().y, &k)) {
                  y1 = std::min(y1, k + 1);
                }
                if (wedge) {
                  // (dx, dy) is in the wedge when d1 x p >= 0 and p x d2 >= 0: linear in dy.
                  double lo = -reach, hi = reach;
                  if (std::abs(d1x) > 1e-9) {
                    (d1x > 0 ? lo : hi) =
                        d1x > 0 ? std::max(lo, d1y * dx / d1x) : std::min(hi, d1y * dx / d1x);
                  }
                  if (std::abs(d2x) > 1e-9) {
                    (d2x > 0 ? hi : lo) =
                        d2x > 0 ? std::min(hi, d2y * dx / d2x) : std::max(lo, d2y * dx / d2x);
                  }
                  if (lo > hi + res) {
                    y0 = 1, y1 = 0;
                    continue;
                  }
                  if (int32_t k; grid.AxisToKey(o.y() + lo, grid.origin().y, &k)) {
                    y0 = std::max(y0, k - 1);
                  }
                  if (int32_t k; grid.AxisToKey(o.y() + hi, grid.origin().y, &k)) {
                    y1 = std::min(y1, k + 1);
                  }
                }
                if (y0 <= y1) lo_y = std::min(lo_y, y0), hi_y = std::max(hi_y, y1);
              }
              if (lo_y > hi_y) continue;
              const double cx0 = grid.AxisCenter(x0, grid.origin().x) - o.x();
              const double cx1 = grid.AxisCenter(x1, grid.origin().x) - o.x();
              for (int32_t by = FreeColumnsVoxel::BlockKey(0, lo_y).y; by <= hi_y; by += kSide) {
                const int32_t y0 = std::max(by, min_y), y1 = std::min(by + kSide - 1, max_y);
                const Cover c = cover(cx0, cx1, grid.AxisCenter(y0, grid.origin().y) - o.y(),
                                      grid.AxisCenter(y1, grid.origin().y) - o.y());
                if (c == Cover::kNone) continue;
                FreeColumnsVoxel block;
                for (int32_t kx = x0; kx <= x1; ++kx) {
                  if (c == Cover::kAll) {
                    for (int32_t ky = y0; ky <= y1; ++ky) {
                      block.counts[FreeColumnsVoxel::Index(kx, ky)] = 1;
                    }
                    continue;
                  }
                  const double dx = grid.AxisCenter(kx, grid.origin().x) - o.x();
                  for (int32_t ky = std::max(y0, ys0[size_t(kx - bx)]);
                       ky <= std::min(y1, ys1[size_t(kx - bx)]); ++ky) {
                    if (in_fan(dx, grid.AxisCenter(ky, grid.origin().y) - o.y())) {
                      block.counts[FreeColumnsVoxel::Index(kx, ky)] = 1;
                    }
                  }
                }
                if (!block.IsEmpty()) out.push_back({{bx, by, 0}, block});
              }
            }
          });
    }
  }
  // The camera's own column: into its block when the fan has it, else a block of its own.
  std::optional<Item> camera_block;
  if (mark_camera) {
    const VoxelKey k = FreeColumnsVoxel::BlockKey(camera_x, camera_y);
    const int slot = FreeColumnsVoxel::Index(camera_x, camera_y);
    bool merged = false;
    for (std::vector<Item>& p : item_pieces) {
      const auto at = std::lower_bound(p.begin(), p.end(), k,
                                       [](const Item& a, const VoxelKey& b) { return a.key < b; });
      if (at != p.end() && at->key == k) {
        at->data.counts[slot] = 1;
        merged = true;
        break;
      }
    }
    if (!merged) {
      camera_block = Item{k, {}};
      camera_block->data.counts[slot] = 1;
    }
  }
  // The pieces in order (their keys ascend), the camera's block where its key sorts.
  size_t total = camera_block ? 1 : 0;
  for (const std::vector<Item>& p : item_pieces) total += p.size();
  batch->Reserve(total);
  for (const std::vector<Item>& p : item_pieces) {
    std::span<const Item> rest(p);
    if (camera_block) {
      const auto at = std::lower_bound(rest.begin(), rest.end(), camera_block->key,
                                       [](const Item& a, const VoxelKey& b) { return a.key < b; });
      if (at != rest.end()) {
        batch->AppendSorted(rest.first(size_t(at - rest.begin())));
        batch->AppendSorted({&*camera_block, 1});
        camera_block.reset();
        rest = rest.subspan(size_t(at - rest.begin()));
      }
    }
    batch->AppendSorted(rest);
  }
  if (camera_block) batch->AppendSorted({&*camera_block, 1});
  for (const Item& item : batch->items()) stats.columns += size_t(item.data.Columns());
  return stats;
}

}  // namespace skimap::perception
