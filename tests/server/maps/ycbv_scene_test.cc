// The real YCB-Video sample (../shared/data/ycbv-0000, 10 Kinect frames of objects on a
// table) streamed through skimapd at 1 cm: the map must show what is physically there. The
// sample's world frame has z roughly up with the table near z = 0 and the floor below it.
//
// Checks and tolerances: the table is a plane (weighted median absolute residual <= 1.2 cm:
// the real sensor distorts depth by about that at 0.5-1.5 m); the floor seen past the table is
// parallel to it (<= 3 degrees) and 0.6-0.9 m below it (a table); the annotated objects
// (ground-truth poses, independent of the depth images) have their centres 1.5-6 cm above
// the table plane (they are 3-10 cm tall and stand on it), and the height map over each
// object is above the table.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <vector>

#include "tests/server/maps/scene_fixture.h"

namespace skimap::testing {
namespace {

struct Plane {
  double a = 0, b = 0, c = 0;  // z = a x + b y + c
  double Residual(const Eigen::Vector3d& p) const { return p.z() - (a * p.x() + b * p.y() + c); }
  Eigen::Vector3d Normal() const { return Eigen::Vector3d(-a, -b, 1).normalized(); }
};

// Weighted least squares z = a x + b y + c, then one refit without points off by > 2 cm.
Plane FitPlane(const std::vector<Eigen::Vector3d>& points, const std::vector<double>& weights) {
  Plane plane;
  std::vector<bool> use(points.size(), true);
  for (int round = 0; round < 2; ++round) {
    Eigen::Matrix3d ata = Eigen::Matrix3d::Zero();
    Eigen::Vector3d atz = Eigen::Vector3d::Zero();
    for (size_t i = 0; i < points.size(); ++i) {
      if (!use[i]) continue;
      const Eigen::Vector3d row(points[i].x(), points[i].y(), 1);
      ata += weights[i] * row * row.transpose();
      atz += weights[i] * row * points[i].z();
    }
    const Eigen::Vector3d x = ata.ldlt().solve(atz);
    plane = {x(0), x(1), x(2)};
    for (size_t i = 0; i < points.size(); ++i) use[i] = std::abs(plane.Residual(points[i])) < 0.02;
  }
  return plane;
}

// Object centres in the world from frame 0's ground truth: inv(T_w2c) * t_m2c, metres.
std::vector<Eigen::Vector3d> ObjectCentres(const std::string& scene) {
  std::ifstream cam_in(scene + "/scene_camera.json"), gt_in(scene + "/scene_gt.json");
  const nlohmann::json cam = nlohmann::json::parse(cam_in)["0"];
  const nlohmann::json gt = nlohmann::json::parse(gt_in)["0"];
  Eigen::Matrix3d r_w2c;
  Eigen::Vector3d t_w2c;
  for (int i = 0; i < 9; ++i) r_w2c(i / 3, i % 3) = cam["cam_R_w2c"][i];
  for (int i = 0; i < 3; ++i) t_w2c(i) = double(cam["cam_t_w2c"][i]) / 1000;
  std::vector<Eigen::Vector3d> out;
  for (const auto& object : gt) {
    Eigen::Vector3d t_m2c;
    for (int i = 0; i < 3; ++i) t_m2c(i) = double(object["cam_t_m2c"][i]) / 1000;
    out.push_back(r_w2c.transpose() * (t_m2c - t_w2c));
  }
  return out;
}

// Median of |residual| with each voxel counted by its weight (observations).
double MedianAbsResidual(const Plane& plane, const std::vector<Eigen::Vector3d>& points,
                         const std::vector<double>& weights) {
  std::vector<std::pair<double, double>> r;
  double total = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    r.emplace_back(std::abs(plane.Residual(points[i])), weights[i]);
    total += weights[i];
  }
  std::sort(r.begin(), r.end());
  double sum = 0;
  for (const auto& [residual, weight] : r) {
    if ((sum += weight) >= total / 2) return residual;
  }
  return r.back().first;
}

// Highest height-map value within `radius` of (x, y); NaN when nothing there was seen.
double TopNear(const v1::HeightMap& map, double x, double y, double radius) {
  double top = std::nan("");
  for (uint32_t j = 0; j < map.height(); ++j) {
    for (uint32_t i = 0; i < map.width(); ++i) {
      const double cx = map.origin_x() + (i + 0.5) * map.resolution();
      const double cy = map.origin_y() + (j + 0.5) * map.resolution();
      const double h = map.heights(j * map.width() + i);
      if (std::hypot(cx - x, cy - y) <= radius && !std::isnan(h) && !(h <= top)) top = h;
    }
  }
  return top;
}

TEST(YcbvSceneTest, TableIsAFlatPlaneAboveTheFloorAndObjectsStandOnIt) {
  const std::string scene = std::string(SKIMAP_YCBV_DIR) + "/test/000000";
  std::unique_ptr<server::Server> server = StartServer();
  ASSERT_NE(server, nullptr);
  auto client = client::MapClient::Connect(absl::StrCat("127.0.0.1:", server->grpc_port()));
  v1::CreateMapRequest create;
  create.set_map_id("ycbv");
  create.mutable_options()->set_resolution(0.01);
  ASSERT_TRUE(client->CreateMap(create).ok());
  StreamWithCli(server->grpc_port(), scene, "ycbv");
  auto info = client->GetMap("maps/ycbv");
  ASSERT_TRUE(info.ok());
  ASSERT_EQ(info->stats().frames(), 10u);

  v1::GetVoxelsRequest all;
  all.set_map("maps/ycbv");
  auto voxels = client->GetAllVoxels(all);
  ASSERT_TRUE(voxels.ok()) << voxels.status();
  const std::vector<Eigen::Vector3d> objects = ObjectCentres(scene);
  ASSERT_EQ(objects.size(), 3u);
  // Table candidates: near z = 0, outside 8 cm discs around the objects; floor: far below.
  std::vector<Eigen::Vector3d> table, floor;
  std::vector<double> table_w, floor_w;
  for (const v1::Voxel& v : *voxels) {
    const Eigen::Vector3d p(v.center().x(), v.center().y(), v.center().z());
    bool near_object = false;
    for (const Eigen::Vector3d& o : objects) near_object |= (p - o).head<2>().norm() < 0.08;
    if (std::abs(p.z()) < 0.06 && !near_object) {
      table.push_back(p);
      table_w.push_back(v.weight());
    } else if (p.z() < -0.4) {
      floor.push_back(p);
      floor_w.push_back(v.weight());
    }
  }
  // Measured 2026-11-23: 2470 table voxels, 1903 floor voxels; floors at two thirds.
  ASSERT_GE(table.size(), 1645u);
  ASSERT_GE(floor.size(), 1265u);
  const Plane table_plane = FitPlane(table, table_w), floor_plane = FitPlane(floor, floor_w);
  const double flatness = MedianAbsResidual(table_plane, table, table_w);
  const double angle_deg =
      std::acos(std::min(1.0, table_plane.Normal().dot(floor_plane.Normal()))) * 180 / M_PI;
  // Height of the table over the floor, along the normal, below the objects.
  const Eigen::Vector3d at(objects[0].x(), objects[0].y(), 0);
  const double table_z = table_plane.a * at.x() + table_plane.b * at.y() + table_plane.c;
  const double floor_z = floor_plane.a * at.x() + floor_plane.b * at.y() + floor_plane.c;
  const double table_height = (table_z - floor_z) * floor_plane.Normal().z();
  std::printf(
      "table: %zu voxels, median |residual| %.4f m; floor %zu voxels; angle %.2f deg; "
      "table height %.3f m\n",
      table.size(), flatness, floor.size(), angle_deg, table_height);
  // Measured 2026-11-23: flatness 9.3 mm (ceiling 4/3: 12.4 mm), angle 2.87 degrees (the
  // table is not quite parallel to the floor in the data; ceiling kept at 3.0), table
  // height 0.717 m (a fact of the scene: 0.6-0.9 m).
  EXPECT_LE(flatness, 0.012);
  EXPECT_LE(angle_deg, 3.0);
  EXPECT_GT(table_height, 0.6);
  EXPECT_LT(table_height, 0.9);

  v1::GetHeightMapRequest heights;
  heights.set_map("maps/ycbv");
  auto height_map = client->GetHeightMap(heights);
  ASSERT_TRUE(height_map.ok()) << height_map.status();
  for (const Eigen::Vector3d& o : objects) {
    const double above = table_plane.Residual(o) * table_plane.Normal().z();
    const double top = TopNear(*height_map, o.x(), o.y(), 0.05);  // the mug is hollow
    const double top_above = top - (table_plane.a * o.x() + table_plane.b * o.y() + table_plane.c);
    std::printf("object centre %.3f m above the table, height map %.3f m above\n", above,
                top_above);
    // Measured 2026-11-23: centres 0.034-0.044 m above the table (a physical range for
    // these objects, kept), height-map tops 0.077-0.084 m: bounds at two thirds of the
    // lowest and 4/3 of the highest.
    EXPECT_GT(above, 0.015);
    EXPECT_LT(above, 0.06);
    EXPECT_GT(top_above, 0.051);  // NaN (nothing seen) fails too
    EXPECT_LT(top_above, 0.112);
  }
}

}  // namespace
}  // namespace skimap::testing
