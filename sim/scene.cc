// Room construction and scene_geometry.json. See scene.h for the contract.
#include "sim/scene.h"

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>

#include "absl/strings/str_cat.h"
#include "dataset/json_util.h"

namespace skimap::sim {

float Uniform(std::mt19937_64& rng, float lo, float hi) {
  return lo + (hi - lo) * static_cast<float>(rng() >> 40) / 16777216.0f;
}

Lighting RandomLighting(std::mt19937_64& rng) {
  Lighting l;
  const float az = Uniform(rng, 0, 6.2832f), el = Uniform(rng, 0.7f, 1.2f);
  l.dir_world =
      -Eigen::Vector3f(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
  l.ambient = Uniform(rng, 0.35f, 0.55f);
  l.diffuse = Uniform(rng, 0.5f, 0.7f);
  l.exposure = Uniform(rng, 0.85f, 1.15f);
  l.tint = {Uniform(rng, 0.92f, 1.08f), Uniform(rng, 0.95f, 1.05f), Uniform(rng, 0.92f, 1.08f)};
  return l;
}

namespace {

using Eigen::Vector2f;
using Eigen::Vector3f;

// Rounds to whole centimetres so the documented geometry has short exact numbers.
float Cm(float v) { return std::round(v * 100.f) / 100.f; }

void AddBox(SceneLayout& s, std::string name, std::string kind, Vector3f min, Vector3f max) {
  s.boxes.push_back({std::move(name), std::move(kind), (min + max) / 2, max - min});
}

void AddTable(SceneLayout& s, int i, Vector2f c, Vector2f size, float h) {
  const std::string n = absl::StrCat("table_", i);
  const Vector2f lo = c - size / 2, hi = c + size / 2;
  AddBox(s, n + "_top", "table_top", {lo.x(), lo.y(), h - 0.03f}, {hi.x(), hi.y(), h});
  const float leg = 0.05f, in = 0.04f;
  for (int k = 0; k < 4; ++k) {
    const float x = (k & 1) ? hi.x() - in - leg : lo.x() + in;
    const float y = (k & 2) ? hi.y() - in - leg : lo.y() + in;
    AddBox(s, absl::StrCat(n, "_leg_", k), "table_leg", {x, y, 0}, {x + leg, y + leg, h - 0.03f});
  }
  s.supports.push_back({n, lo, hi, h, 10});
}

// A shelf unit against a wall: footprint [lo, hi], boards every `step` metres.
void AddShelf(SceneLayout& s, int i, Vector2f lo, Vector2f hi, bool along_x) {
  const std::string n = absl::StrCat("shelf_", i);
  const float t = 0.02f, top = 1.8f, step = 0.42f;
  if (along_x) {
    AddBox(s, n + "_side_0", "shelf_side", {lo.x(), lo.y(), 0}, {lo.x() + t, hi.y(), top});
    AddBox(s, n + "_side_1", "shelf_side", {hi.x() - t, lo.y(), 0}, {hi.x(), hi.y(), top});
  } else {
    AddBox(s, n + "_side_0", "shelf_side", {lo.x(), lo.y(), 0}, {hi.x(), lo.y() + t, top});
    AddBox(s, n + "_side_1", "shelf_side", {lo.x(), hi.y() - t, 0}, {hi.x(), hi.y(), top});
  }
  for (int b = 0; b < 5; ++b) {
    const float z = 0.08f + b * step;
    const Vector2f blo = along_x ? Vector2f(lo.x() + t, lo.y()) : Vector2f(lo.x(), lo.y() + t);
    const Vector2f bhi = along_x ? Vector2f(hi.x() - t, hi.y()) : Vector2f(hi.x(), hi.y() - t);
    const std::string bn = absl::StrCat(n, "_board_", b);
    AddBox(s, bn, "shelf_board", {blo.x(), blo.y(), z - t}, {bhi.x(), bhi.y(), z});
    if (b < 4) s.supports.push_back({bn, blo, bhi, z, step - t});
  }
}

bool IsFloor(const Support& s) { return s.name.rfind("floor", 0) == 0; }

// Places `mesh` on a random support (a floor strip when `on_floor`, else any other) with a
// random yaw (and lying boxes); false if no free spot was found after some tries.
bool Place(SceneLayout& s, const Mesh& mesh, Placement p, bool on_floor, std::mt19937_64& rng,
           std::vector<std::pair<std::string, Vector3f>>& taken) {  // (support, x y radius)
  std::vector<const Support*> candidates;
  for (const Support& sup : s.supports) {
    if (IsFloor(sup) == on_floor) candidates.push_back(&sup);
  }
  if (candidates.empty()) return false;
  for (int attempt = 0; attempt < 60; ++attempt) {
    const Support& sup = *candidates[rng() % candidates.size()];
    Eigen::Matrix3f R =
        Eigen::AngleAxisf(Uniform(rng, -3.14159f, 3.14159f), Vector3f::UnitZ()).toRotationMatrix();
    if (rng() % 5 == 0) R = R * Eigen::AngleAxisf(1.5707963f, Vector3f::UnitX()).toRotationMatrix();
    Eigen::AlignedBox3f b;
    for (const Vector3f& v : mesh.positions) b.extend(R * v);
    if (b.sizes().z() > sup.clearance - 0.02f) continue;
    const float r = 0.5f * b.sizes().head<2>().norm();
    const Vector2f lo = sup.min.array() + r + 0.02f, hi = sup.max.array() - r - 0.02f;
    if (lo.x() > hi.x() || lo.y() > hi.y()) continue;
    const Vector2f xy(Uniform(rng, lo.x(), hi.x()), Uniform(rng, lo.y(), hi.y()));
    bool free = true;
    for (const auto& [name, t] : taken) {
      if (name == sup.name && (t.head<2>() - xy).norm() < t.z() + r + 0.01f) free = false;
    }
    if (!free) continue;
    taken.push_back({sup.name, Vector3f(xy.x(), xy.y(), r)});
    p.support = sup.name;
    p.T_wm.linear() = R;
    p.T_wm.translation() = Vector3f(xy.x(), xy.y(), sup.z - b.min().z());
    (p.obj_id > 0 ? s.objects : s.distractors).push_back(p);
    return true;
  }
  return false;
}

// Rounds a float to 0.1 mm for the JSON (the float geometry itself is exact to ~1e-7 m).
double R4(float v) { return std::round(static_cast<double>(v) * 1e4) / 1e4; }

nlohmann::ordered_json Vec(const Vector3f& v) { return {R4(v.x()), R4(v.y()), R4(v.z())}; }

nlohmann::ordered_json PlacementJson(const Placement& p) {
  nlohmann::ordered_json j;
  const Eigen::Matrix3f& R = p.T_wm.linear();
  nlohmann::ordered_json r = nlohmann::ordered_json::array();
  for (int i = 0; i < 9; ++i) r.push_back(std::round(R(i / 3, i % 3) * 1e6) / 1e6);
  j["support"] = p.support;
  j["R_wm"] = r;
  j["t_wm"] = {p.T_wm.translation().x(), p.T_wm.translation().y(), p.T_wm.translation().z()};
  return j;
}

}  // namespace

SceneLayout MakeRoom(const RoomSpec& spec, const std::vector<ObjectModel>& objects,
                     const std::vector<Mesh>& distractors, std::mt19937_64& rng) {
  SceneLayout s;
  s.spec = spec;
  const float w = spec.width / 2, d = spec.depth / 2, h = spec.height, t = 0.1f;
  AddBox(s, "floor", "floor", {-w - t, -d - t, -t}, {w + t, d + t, 0});
  AddBox(s, "ceiling", "ceiling", {-w - t, -d - t, h}, {w + t, d + t, h + t});
  AddBox(s, "wall_north", "wall", {-w - t, d, 0}, {w + t, d + t, h});
  AddBox(s, "wall_south", "wall", {-w - t, -d - t, 0}, {w + t, -d, h});
  AddBox(s, "wall_east", "wall", {w, -d, 0}, {w + t, d, h});
  AddBox(s, "wall_west", "wall", {-w - t, -d, 0}, {-w, d, h});
  // Tables in the middle band, inside the robot's walking loop (1 m from the walls).
  for (int i = 0; i < spec.tables; ++i) {
    const Vector2f size = (i % 2 == 0) ? Vector2f(1.2f, 0.7f) : Vector2f(0.8f, 0.8f);
    const float cx = Cm(-w + (i + 1) * spec.width / (spec.tables + 1));
    const float cy = Cm(Uniform(rng, -0.25f, 0.25f) * (d - 1.6f));
    AddTable(s, i, {cx, cy}, size, Cm(Uniform(rng, 0.70f, 0.78f)));
  }
  // Shelves against the north, south, west walls (0.35 m deep).
  for (int i = 0; i < spec.shelves; ++i) {
    const float len = 1.4f, dep = 0.35f;
    const float x0 = Cm(Uniform(rng, -w + 0.8f, w - 0.8f - len));
    if (i % 3 == 0) AddShelf(s, i, {x0, d - dep}, {x0 + len, d}, true);
    if (i % 3 == 1) AddShelf(s, i, {x0, -d}, {x0 + len, -d + dep}, true);
    if (i % 3 == 2) AddShelf(s, i, {-w, -len / 2}, {-w + dep, len / 2}, false);
  }
  // Clutter in the corners: cabinets and chair-like blocks (no objects on them).
  for (int i = 0; i < spec.clutter; ++i) {
    const float sx = (i % 2) ? 1 : -1, sy = (i % 4 < 2) ? 1 : -1;
    const Vector3f size(Cm(Uniform(rng, 0.4f, 0.6f)), Cm(Uniform(rng, 0.4f, 0.6f)),
                        Cm(Uniform(rng, 0.45f, 1.1f)));
    const Vector3f c(sx * (w - 0.05f - size.x() / 2), sy * (d - 0.45f - size.y() / 2),
                     size.z() / 2);
    AddBox(s, absl::StrCat("clutter_", i), "clutter", c - size / 2, c + size / 2);
  }
  // Floor strips between the tables and the robot's loop (1 m from the walls), both sides.
  if (spec.floor_objects > 0) {
    float table_y = 0;
    for (const Support& sup : s.supports) {
      if (sup.name.rfind("table", 0) != 0) continue;
      table_y = std::max({table_y, std::abs(sup.min.y()), std::abs(sup.max.y())});
    }
    const float y0 = table_y + 0.15f, y1 = d - 1.4f;
    if (y1 - y0 >= 0.25f) {
      s.supports.push_back({"floor_0", {-w + 1.3f, y0}, {w - 1.3f, y1}, 0, 10});
      s.supports.push_back({"floor_1", {-w + 1.3f, -y1}, {w - 1.3f, -y0}, 0, 10});
    }
  }
  std::vector<std::pair<std::string, Vector3f>> taken;
  // A random subset of the database objects (Fisher-Yates on our own draws: portable).
  std::vector<int> order(objects.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int>(i);
  for (size_t i = order.size(); i > 1; --i) std::swap(order[i - 1], order[rng() % i]);
  for (int k = 0; k < spec.objects && k < static_cast<int>(objects.size()); ++k) {
    const int i = order[k];
    Placement p;
    p.obj_id = objects[i].obj_id;
    p.mesh_index = i;
    Place(s, objects[i].mesh, p, k < spec.floor_objects, rng, taken);
  }
  for (int i = 0; i < spec.distractors && !distractors.empty(); ++i) {
    Placement p;
    p.mesh_index = i % static_cast<int>(distractors.size());
    Place(s, distractors[p.mesh_index], p, false, rng, taken);
  }
  return s;
}

Mesh BuildStructureMesh(const SceneLayout& layout, const std::vector<Texture>& textures) {
  Mesh out;
  const Texture floor_tex = textures[textures.size() / 2];
  for (const WorldBox& b : layout.boxes) {
    Texture tex;
    float tiles = 1;
    if (b.kind == "floor") {
      tex = floor_tex;
      tiles = std::max(b.size.x(), b.size.y()) / 1.5f;
    } else if (b.kind == "wall") {
      tex = FlatTexture(205, 215, 225);
    } else if (b.kind == "ceiling") {
      tex = FlatTexture(235, 235, 235);
    } else if (b.kind.rfind("table", 0) == 0) {
      tex = FlatTexture(60, 100, 150);
    } else if (b.kind.rfind("shelf", 0) == 0) {
      tex = FlatTexture(120, 150, 170);
    } else {
      tex = FlatTexture(90, 80, 70);
    }
    out.Append(MakeBox(b.size, tex, tiles), Eigen::Affine3f(Eigen::Translation3f(b.center)));
  }
  return out;
}

absl::Status WriteSceneGeometry(const SceneLayout& s, const std::vector<ObjectModel>& objects,
                                const std::string& path) {
  nlohmann::ordered_json j;
  j["format"] = "skimap-sim scene geometry v1";
  j["frame"] = "world, metres, z up, floor top at z = 0; boxes are axis-aligned (center, size)";
  j["name"] = s.spec.name;
  j["room"] = {{"min", Vec({-s.spec.width / 2, -s.spec.depth / 2, 0})},
               {"max", Vec({s.spec.width / 2, s.spec.depth / 2, s.spec.height})}};
  nlohmann::ordered_json boxes = nlohmann::ordered_json::array();
  for (const WorldBox& b : s.boxes) {
    boxes.push_back(
        {{"name", b.name}, {"kind", b.kind}, {"center", Vec(b.center)}, {"size", Vec(b.size)}});
  }
  j["boxes"] = boxes;
  nlohmann::ordered_json sup = nlohmann::ordered_json::array();
  for (const Support& p : s.supports) {
    sup.push_back({{"name", p.name},
                   {"top_height", R4(p.z)},
                   {"min_xy", {R4(p.min.x()), R4(p.min.y())}},
                   {"max_xy", {R4(p.max.x()), R4(p.max.y())}}});
  }
  j["supports"] = sup;
  nlohmann::ordered_json objs = nlohmann::ordered_json::array();
  for (const Placement& p : s.objects) {
    nlohmann::ordered_json o;
    o["obj_id"] = p.obj_id;
    o["name"] = objects[p.obj_id - 1].name;
    o.update(PlacementJson(p));
    objs.push_back(o);
  }
  j["objects"] = objs;
  nlohmann::ordered_json dis = nlohmann::ordered_json::array();
  for (const Placement& p : s.distractors) {
    nlohmann::ordered_json o;
    o["distractor"] = p.mesh_index;
    o.update(PlacementJson(p));
    dis.push_back(o);
  }
  j["distractors"] = dis;
  return dataset::internal::WriteTextFile(path, j.dump(1) + "\n");
}

}  // namespace skimap::sim
