// Obstacles a later view saw through, cleared from the occupancy grid.
//
//   GridViews views;                                   // in MapState, written by the worker
//   views.Offer(GridViews::MakeView(sequence, frame));  // MakeView outside the map's lock
//   ClearSeenThroughCells(state.rgb, bands, state.grid_views, &grid);
//
// A stale obstacle (a chair moved away, a person who walked on) keeps its voxels: their
// weight came from the frames that saw it, and a later frame that looks through the space
// it took adds nothing there (free-space evidence is per column, so it cannot tell a ray
// that passed through a voxel from one that passed over it). The grid asks the depth the
// cameras measured instead.
//
// The views: the latest frame from each vantage point, its depth kept at half resolution
// (every second pixel of every second row). A frame replaces the kept view whose camera
// lies within `min_distance` and `min_angle_deg` of its own, else it is added, the oldest
// view going beyond `capacity` (64 views of 640 x 480 frames: 9.8 MB). Not persisted: a
// reloaded map has the views of the frames its journal replays. UpdatePoses moves a
// frame's view with it (Move), so the grid never depends on the order poses arrived in.
//
// The test of a voxel (a cube `edge` wide around centre p) in one view: the rays of the
// kept pixels around its projection (at most 9 per axis) that pass through the cube, each
// with the depths t_in, t_out at which it enters and leaves it, against the depth d it
// measured, with n = 3 sigma(d) of a Kinect's axial noise (1.2 mm + 1.9 mm (d - 0.4 m)^2):
//   kSeen         one ray measured a surface inside the cube: t_in - n <= d <= t_out + n;
//   kSeenThrough  otherwise, every ray measured and each passed through: d > t_out + n;
//   otherwise (something in front, a ray unmeasured, the cube outside the image or nearer
//   than min_depth, no kept ray through it) the view does not decide, and the next older
//   view is asked. A voxel no view decides is kUndecided.
// ClearSeenThroughCells takes the obstacle from an occupied cell when every band voxel of
// its column (weight >= the grid's min_weight) is kSeenThrough by the newest view that
// decides it: the cell is then free if the floor was seen there, unknown otherwise (and
// free-space evidence may free it after). A thin obstacle stays as long as a kept ray
// through its voxel measures it.
//
// Thread safety: a plain value; MapState's lock guards it (the worker writes, queries read).
#ifndef SERVER_CORE_MAPS_GRID_VIEWS_H_
#define SERVER_CORE_MAPS_GRID_VIEWS_H_

#include <cstddef>
#include <cstdint>
#include <deque>

#include "Eigen/Geometry"
#include "base/thread_pool.h"
#include "codec/image_codec.h"
#include "perception/rgbd_frame.h"
#include "skimap/map_queries.h"
#include "skimap/skimap.h"
#include "skimap/voxel.h"

namespace skimap::server {

class GridViews {
 public:
  struct Options {
    size_t capacity = 64;
    double min_distance = 0.3;  // metres
    double min_angle_deg = 20;
    double min_depth = 0.1;  // metres: the sensor's range starts here (the map's min_depth)
  };

  struct View {
    uint64_t sequence = 0;
    perception::DepthImage depth;      // half resolution
    float depth_scale = 0;             // metres per depth unit
    perception::PinholeCamera camera;  // halved to match `depth`
    Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();
    Eigen::Isometry3f camera_from_world = Eigen::Isometry3f::Identity();
  };

  enum class Verdict { kUndecided, kSeen, kSeenThrough };

  GridViews() = default;
  explicit GridViews(Options options) : options_(options) {}

  // Frame `sequence` as a view (half-resolution depth). REQUIRES: ValidateFrame(frame).
  static View MakeView(uint64_t sequence, const perception::RgbdFrame& frame);

  // Keeps `view` as the newest, replacing a kept view from the same vantage point.
  void Offer(View view);
  // Frame `sequence` moved (UpdatePoses); a frame without a kept view is ignored.
  void Move(uint64_t sequence, const Eigen::Isometry3d& world_from_camera);

  // What the newest deciding view says of the voxel centre `p` (world, metres) of a voxel
  // `edge` metres wide.
  Verdict Decide(const Eigen::Vector3f& p, float edge) const;

  size_t size() const { return views_.size(); }

 private:
  Verdict DecideIn(const View& view, const Eigen::Vector3f& p, float edge) const;

  Options options_;
  std::deque<View> views_;  // oldest first
};

// Frees (or makes unknown) every occupied cell of `grid` whose band voxels in `rgb` are all
// seen through (above). `bands` are the ones `grid` was computed with.
// With `pool` (not owned, may be null), rows of cells run on its threads; the answer is
// the same. REQUIRES: grid->geometry was made for rgb's grid; not called from inside the
// pool's tasks.
void ClearSeenThroughCells(const SkiMap<RGBWeightedVoxel>& rgb,
                           const skimap::internal::OccupancyBands& bands, const GridViews& views,
                           OccupancyGrid* grid, ThreadPool* pool = nullptr);

}  // namespace skimap::server

#endif  // SERVER_CORE_MAPS_GRID_VIEWS_H_
