// perception::BuildFreeSpaceBatch against the geometry of an analytic scene (a floor and a
// box, ray-cast exactly): which columns a frame's fan of rays frees, with the camera inside
// the carved band and above it, across gaps of missing depth, and that a pool changes
// nothing.
#include "perception/free_space.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <utility>
#include <vector>

namespace skimap::perception {
namespace {

struct SceneBox {
  Eigen::Vector3d min, max;
};

struct SyntheticCamera {
  int width = 160, height = 120;
  double fx = 120, fy = 120, cx = 79.5, cy = 59.5;
};

// Camera at `position` looking along `forward` (world z up), as a world <- camera pose.
Eigen::Isometry3d LookingAlong(const Eigen::Vector3d& position, Eigen::Vector3d forward) {
  forward.normalize();
  const Eigen::Vector3d right = forward.cross(Eigen::Vector3d::UnitZ()).normalized();
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() << right, forward.cross(right), forward;
  pose.translation() = position;
  return pose;
}

// Depth in millimetres (0 = no hit) of the floor z = 0 and `box`, ray-cast exactly.
std::vector<uint16_t> RenderDepth(const Eigen::Isometry3d& pose, const SyntheticCamera& c,
                                  const SceneBox& box) {
  std::vector<uint16_t> depth(size_t(c.width) * c.height, 0);
  const Eigen::Vector3d& o = pose.translation();
  for (int v = 0; v < c.height; ++v) {
    for (int u = 0; u < c.width; ++u) {
      const Eigen::Vector3d d =
          pose.linear() * Eigen::Vector3d((u - c.cx) / c.fx, (v - c.cy) / c.fy, 1);
      double t = d.z() < 0 ? -o.z() / d.z() : std::numeric_limits<double>::infinity();
      double t0 = 0, t1 = t;
      for (int a = 0; a < 3; ++a) {
        double ta = (box.min[a] - o[a]) / d[a], tb = (box.max[a] - o[a]) / d[a];
        if (ta > tb) std::swap(ta, tb);
        t0 = std::max(t0, ta);
        t1 = std::min(t1, tb);
      }
      if (t0 <= t1) t = std::min(t, t0);
      if (std::isfinite(t) && t < 60)
        depth[size_t(v) * c.width + u] = uint16_t(std::lround(t * 1000));
    }
  }
  return depth;
}

RgbdFrame Frame(const Eigen::Isometry3d& pose, const SceneBox& box, const SyntheticCamera& c = {}) {
  RgbdFrame f;
  f.camera = {c.fx, c.fy, c.cx, c.cy, c.width, c.height};
  f.depth.width = c.width;
  f.depth.height = c.height;
  f.depth.pixels = RenderDepth(pose, c, box);
  f.depth_scale = 0.001;
  f.pose.translation = pose.translation();
  f.pose.rotation = Eigen::Quaterniond(pose.linear());
  return f;
}

// The free columns of a frame at 5 cm, as (x, y) keys.
std::set<std::pair<int32_t, int32_t>> Carve(const RgbdFrame& f, const FreeSpaceOptions& o = {},
                                            ThreadPool* pool = nullptr,
                                            FreeSpaceStats* stats = nullptr) {
  VoxelBatch<FreeColumnsVoxel> batch;
  const FreeSpaceStats s = BuildFreeSpaceBatch(f, Grid(0.05), {}, o, &batch, pool);
  if (stats != nullptr) *stats = s;
  std::set<std::pair<int32_t, int32_t>> out;
  const auto items = batch.items();
  for (size_t i = 0; i < items.size(); ++i) {
    const auto& item = items[i];
    EXPECT_EQ(item.key.z, 0);
    EXPECT_EQ(FreeColumnsVoxel::BlockKey(item.key.x, item.key.y), item.key) << "a block's key";
    if (i > 0) {
      EXPECT_LT(items[i - 1].key, item.key) << "sorted, one item per block";
    }
    EXPECT_FALSE(item.data.IsEmpty());
    for (int32_t dx = 0; dx < FreeColumnsVoxel::kSide; ++dx) {
      for (int32_t dy = 0; dy < FreeColumnsVoxel::kSide; ++dy) {
        const uint32_t count =
            item.data.counts[FreeColumnsVoxel::Index(item.key.x + dx, item.key.y + dy)];
        EXPECT_LE(count, 1u);
        if (count == 1) out.insert({item.key.x + dx, item.key.y + dy});
      }
    }
  }
  EXPECT_EQ(out.size(), s.columns);
  return out;
}

bool Free(const std::set<std::pair<int32_t, int32_t>>& cols, double x, double y) {
  return cols.contains({int32_t(std::floor(x / 0.05)), int32_t(std::floor(y / 0.05))});
}

// A wall 3 m ahead of a camera 0.8 m up looking along +x (the camera is in the band).
SceneBox Wall() {
  SceneBox wall;
  wall.min = {3.0, -4.0, 0.0};
  wall.max = {3.1, 4.0, 2.0};
  return wall;
}

TEST(FreeSpaceTest, TheFanBeforeTheWallIsFreeAndNothingBehindIt) {
  const RgbdFrame f = Frame(LookingAlong({0, 0, 0.8}, {1, 0, 0}), Wall());
  FreeSpaceStats stats;
  const auto cols = Carve(f, {}, nullptr, &stats);
  EXPECT_GT(stats.rays, 1000u);
  EXPECT_EQ(stats.columns, cols.size());
  // The rays of the stride lattice (u = 0 .. 156) span tan = -79.5 / 120 .. 76.5 / 120.
  for (double x = 0.1; x < 2.9; x += 0.05) {
    const double half_width = x * 76.5 / 120.0;
    for (double y = -half_width + 0.1; y < half_width - 0.1; y += 0.05) {
      EXPECT_TRUE(Free(cols, x, y)) << x << ", " << y;
    }
  }
  EXPECT_TRUE(Free(cols, 0.01, 0.01)) << "the camera's own column";
  for (const auto& [kx, ky] : cols) {
    const double x = (kx + 0.5) * 0.05, y = (ky + 0.5) * 0.05;
    EXPECT_LT(x, 3.0) << "behind the wall";
    EXPECT_GT(x, -0.1) << "behind the camera";
    EXPECT_LE(std::abs(y), std::max(0.0, x) * 80.0 / 120.0 + 0.1) << "outside the view";
  }
}

TEST(FreeSpaceTest, ACameraAboveTheBandCarvesFromWhereItsRaysEnterIt) {
  // 2.5 m up, 45 degrees down onto the floor: rays enter the band (top 1.5 m) 1 m (straight
  // ahead) from the camera's column and leave it where they hit the floor at 2.5 m.
  const RgbdFrame f =
      Frame(LookingAlong({0, 0, 2.5}, {1, 0, -1}), SceneBox{{50, 50, 0}, {51, 51, 1}});
  const auto cols = Carve(f);
  ASSERT_FALSE(cols.empty());
  EXPECT_FALSE(Free(cols, 0.01, 0.01)) << "no ray is in the band under the camera";
  EXPECT_FALSE(Free(cols, 0.4, 0.01));
  EXPECT_TRUE(Free(cols, 1.4, 0.01));
  EXPECT_TRUE(Free(cols, 2.0, 0.01));
  for (const auto& [kx, ky] : cols) {
    const double x = (kx + 0.5) * 0.05, y = (ky + 0.5) * 0.05;
    // Every free column lies where some ray crosses the band: between the steepest ray's
    // entry (45 + 26.6 degrees down: 0.33 m) and the shallowest's floor hit (13.3 m).
    EXPECT_GT(std::hypot(x, y), 0.3) << x << ", " << y;
  }
}

TEST(FreeSpaceTest, NarrowGapsOfMissingDepthAreBridgedWideOnesAreNot) {
  const RgbdFrame f = Frame(LookingAlong({0, 0, 0.8}, {1, 0, 0}), Wall());
  auto with_hole = [&](int u0, int u1) {
    RgbdFrame g = f;
    for (int v = 0; v < g.camera.height; ++v) {
      for (int u = u0; u < u1; ++u) g.depth.pixels[size_t(v) * g.camera.width + u] = 0;
    }
    return Carve(g, {.pixel_stride = 4});
  };
  // Straight ahead is column 80; 2 m ahead one pixel is 1.7 cm wide.
  const auto narrow = with_hole(78, 83);  // one ray of the stride lattice (u = 80) missing
  const auto wide = with_hole(60, 101);   // 10 rays: 70 cm at 2 m
  EXPECT_TRUE(Free(narrow, 2.5, 0.01)) << "bridged between its neighbours";
  EXPECT_FALSE(Free(wide, 2.5, 0.01)) << "no evidence across a wide hole";
  EXPECT_FALSE(Free(wide, 0.3, 0.01)) << "not even near the camera: no ray there";
  EXPECT_TRUE(Free(wide, 2.5, 0.8)) << "beside the hole";
}

TEST(FreeSpaceTest, ACameraLookingStraightDownCarvesAllAroundWithoutASeam) {
  // 1.2 m up (in the band), looking down: the rays fan out all around the camera's column
  // and hit the floor 0.3-0.8 m away (the image's half-diagonal is 37 degrees).
  const RgbdFrame f =
      Frame(LookingAlong({0, 0, 1.2}, {0.001, 0, -1}), SceneBox{{50, 50, 0}, {51, 51, 1}});
  const auto cols = Carve(f, {.pixel_stride = 2});
  for (double angle = 0; angle < 2 * M_PI; angle += M_PI / 16) {
    EXPECT_TRUE(Free(cols, 0.2 * std::cos(angle), 0.2 * std::sin(angle))) << angle;
  }
  EXPECT_FALSE(Free(cols, 1.5, 0));
}

TEST(FreeSpaceTest, APoolGivesTheSameBatch) {
  ThreadPool pool(2);
  for (const Eigen::Isometry3d& pose :
       {LookingAlong({0, 0, 0.8}, {1, 0, 0}), LookingAlong({0.3, -0.2, 2.5}, {1, 0.4, -1}),
        LookingAlong({0, 0, 1.0}, {0.01, 0, -1})}) {
    const RgbdFrame f = Frame(pose, Wall());
    EXPECT_EQ(Carve(f, {.pixel_stride = 2}), Carve(f, {.pixel_stride = 2}, &pool));
  }
}

TEST(FreeSpaceTest, BadOptionsNameTheField) {
  EXPECT_NE(ValidateFreeSpaceOptions({.pixel_stride = 0}).message().find("carve_pixel_stride"),
            std::string::npos);
  EXPECT_NE(ValidateFreeSpaceOptions({.min_z = 2, .max_z = 1}).message().find("band"),
            std::string::npos);
}

}  // namespace
}  // namespace skimap::perception
