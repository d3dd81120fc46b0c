// The sim's scene description (scene_geometry.json, docs/sim.md) for tests that compare a
// map with the ground truth, and raster helpers for grids and height maps from the API.
#ifndef TESTS_SERVER_MAPS_SCENE_GEOMETRY_H_
#define TESTS_SERVER_MAPS_SCENE_GEOMETRY_H_

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace skimap::testing {

// An axis-aligned box of the room, world metres.
struct GeometryBox {
  std::string name, kind;  // kind: floor, ceiling, wall, table_top, table_leg, shelf_*, clutter
  double min[3], max[3];
  // Distance in the xy plane from (x, y) to the box's footprint (0 inside).
  double FootprintDistance(double x, double y) const {
    const double dx = std::max({min[0] - x, 0.0, x - max[0]});
    const double dy = std::max({min[1] - y, 0.0, y - max[1]});
    return std::hypot(dx, dy);
  }
};

struct GeometrySupport {
  std::string name;
  double top_height = 0;
  double min_xy[2], max_xy[2];
};

struct SceneGeometry {
  double room_min[3], room_max[3];
  std::vector<GeometryBox> boxes;
  std::vector<GeometrySupport> supports;

  std::vector<GeometryBox> OfKind(const std::string& kind) const {
    std::vector<GeometryBox> out;
    for (const GeometryBox& b : boxes) {
      if (b.kind == kind) out.push_back(b);
    }
    return out;
  }
  // Distance in xy to the nearest box that is neither floor nor ceiling.
  double FurnitureDistance(double x, double y) const {
    double best = 1e9;
    for (const GeometryBox& b : boxes) {
      if (b.kind != "floor" && b.kind != "ceiling")
        best = std::min(best, b.FootprintDistance(x, y));
    }
    return best;
  }
};

// Reads scene_geometry.json; throws nlohmann::json exceptions on malformed input.
inline SceneGeometry LoadSceneGeometry(const std::string& path) {
  std::ifstream in(path);
  const nlohmann::json j = nlohmann::json::parse(in);
  SceneGeometry g;
  for (int a = 0; a < 3; ++a) {
    g.room_min[a] = j["room"]["min"][a];
    g.room_max[a] = j["room"]["max"][a];
  }
  for (const auto& b : j["boxes"]) {
    GeometryBox box{b["name"], b["kind"], {}, {}};
    for (int a = 0; a < 3; ++a) {
      const double c = b["center"][a], s = b["size"][a];
      box.min[a] = c - s / 2;
      box.max[a] = c + s / 2;
    }
    g.boxes.push_back(box);
  }
  for (const auto& s : j["supports"]) {
    GeometrySupport support{s["name"], s["top_height"], {}, {}};
    for (int a = 0; a < 2; ++a) {
      support.min_xy[a] = s["min_xy"][a];
      support.max_xy[a] = s["max_xy"][a];
    }
    g.supports.push_back(support);
  }
  return g;
}

// Calls fn(x, y, value) with the centre of every cell of an API raster (OccupancyGrid or
// HeightMap layout: row-major, x fastest, origin at the lower-left corner of cell 0).
template <class Raster, class Value, class Fn>
void ForEachCell(const Raster& r, const Value& values, Fn&& fn) {
  for (uint32_t j = 0; j < r.height(); ++j) {
    for (uint32_t i = 0; i < r.width(); ++i) {
      const double x = r.origin_x() + (i + 0.5) * r.resolution();
      const double y = r.origin_y() + (j + 0.5) * r.resolution();
      fn(x, y, values[size_t(j) * r.width() + i]);
    }
  }
}

}  // namespace skimap::testing

#endif  // TESTS_SERVER_MAPS_SCENE_GEOMETRY_H_
