// Room layouts for the test scenes: floor, walls, ceiling, tables, shelves, clutter, the
// database objects and distractors placed on supports with exact 6-DOF poses, and the
// machine-readable description written as scene_geometry.json (docs/sim.md).
//
// World frame: metres, z up, floor top at z = 0, room interior x in [-width/2, width/2],
// y in [-depth/2, depth/2]. All furniture is made of axis-aligned boxes.
//
// Thread safety: values and pure functions.
#ifndef SKIMAP_SIM_SCENE_H_
#define SKIMAP_SIM_SCENE_H_

#include <Eigen/Geometry>
#include <random>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "sim/mesh.h"
#include "sim/objects.h"
#include "sim/rasterizer.h"

namespace skimap::sim {

// An axis-aligned box in the world frame.
struct WorldBox {
  std::string name;  // e.g. "table_0_top", "shelf_1_board_2", "wall_north"
  std::string kind;  // floor, ceiling, wall, table_top, table_leg, shelf_side, shelf_board,
                     // shelf_back, clutter
  Eigen::Vector3f center, size;
};

// A horizontal support rectangle objects stand on (a table top or a shelf board).
struct Support {
  std::string name;          // "table_0" or "shelf_0_board_1"
  Eigen::Vector2f min, max;  // x, y extent of the top face
  float z = 0;               // height of the top face
  float clearance = 10;      // free height above (shelf board spacing), metres
};

// A mesh placed in the room. obj_id > 0: database object (index into the objects list is
// obj_id - 1); obj_id == 0: distractor (mesh_index into the distractor list).
struct Placement {
  int obj_id = 0;
  int mesh_index = 0;
  std::string support;
  Eigen::Isometry3f T_wm = Eigen::Isometry3f::Identity();
};

// What MakeRoom builds.
struct RoomSpec {
  std::string name;
  float width = 6, depth = 5, height = 2.6f;  // interior, metres
  int tables = 2, shelves = 1, clutter = 2;
  int objects = 8;  // database objects placed (ids 1..objects, each once)
  int distractors = 4;
  int floor_objects = 0;  // of `objects`, how many stand on the floor (two strips between
                          // the tables and the walls, "floor_0" / "floor_1"; needs a room
                          // at least 5 m deep)
};

// A complete scene.
struct SceneLayout {
  RoomSpec spec;
  std::vector<WorldBox> boxes;
  std::vector<Support> supports;
  std::vector<Placement> objects;
  std::vector<Placement> distractors;
};

// A float drawn uniformly from [lo, hi) with the top 24 bits of one rng() draw.
float Uniform(std::mt19937_64& rng, float lo, float hi);

// A room's light drawn at random: from above at 40-70 degrees elevation, any azimuth,
// ambient 0.35-0.55, diffuse 0.5-0.7, exposure 0.85-1.15, a slight colour tint.
Lighting RandomLighting(std::mt19937_64& rng);

// Builds a room from the spec; furniture sizes and object poses are drawn from rng.
// REQUIRES: spec.objects <= objects.size(); room at least 3.5 x 3 m.
SceneLayout MakeRoom(const RoomSpec& spec, const std::vector<ObjectModel>& objects,
                     const std::vector<Mesh>& distractors, std::mt19937_64& rng);

// One mesh with every box of the layout (floor, walls, furniture), textured from
// `textures` (the floor tiles a photograph; walls and furniture are flat colours).
Mesh BuildStructureMesh(const SceneLayout& layout, const std::vector<Texture>& textures);

// Writes scene_geometry.json (format in docs/sim.md). kInternal on I/O error.
[[nodiscard]] absl::Status WriteSceneGeometry(const SceneLayout& layout,
                                              const std::vector<ObjectModel>& objects,
                                              const std::string& path);

}  // namespace skimap::sim

#endif  // SKIMAP_SIM_SCENE_H_
