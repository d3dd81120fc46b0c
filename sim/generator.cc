// Presets and orchestration. See generator.h for the contract.
#include "sim/generator.h"

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <random>

#include "absl/strings/str_cat.h"
#include "dataset/json_util.h"
#include "dataset/writer.h"
#include "sim/scene.h"
#include "sim/sequence.h"
#include "sim/trajectory.h"

namespace skimap::sim {
namespace {

namespace fs = std::filesystem;

struct SceneSpec {
  RoomSpec room;
  TrajectoryKind trajectory;
  double speed;          // m/s
  float height = 1.35f;  // camera above the floor (robot, patrol), metres
};

struct Preset {
  int objects;
  std::vector<SceneSpec> scenes;
  int scene_frames;
  std::vector<float> train_elevations;  // degrees, one variant each
  int train_frames;
};

absl::StatusOr<Preset> GetPreset(const std::string& name) {
  using TK = TrajectoryKind;
  // Test scenes are tours from object to object, as SK17's hand-held scans are: a
  // recognition benchmark must show its objects (the earlier orbits and robot loops saw
  // most objects only from 3-5 m, or not at all).
  if (name == "mini") {
    return Preset{
        3, {{{"mini_room", 4.0f, 3.5f, 2.5f, 1, 1, 1, 3, 2}, TK::kTour, 0.3}}, 100, {15, 45}, 12};
  }
  if (name == "sk") {
    return Preset{12,
                  {{{"office", 6.0f, 5.0f, 2.6f, 2, 1, 2, 8, 4}, TK::kTour, 0.3},
                   {{"lab", 8.0f, 6.0f, 2.8f, 3, 2, 3, 9, 5}, TK::kTour, 0.3},
                   {{"store_room", 5.0f, 4.5f, 2.5f, 1, 3, 2, 8, 4}, TK::kTour, 0.3},
                   {{"living_room", 7.0f, 5.0f, 2.6f, 2, 1, 4, 8, 5}, TK::kTour, 0.3},
                   {{"kitchen", 5.5f, 4.5f, 2.5f, 2, 2, 2, 8, 4}, TK::kTour, 0.3}},
                  400,
                  {10, 35, 60},
                  36};
  }
  if (name == "robot") {
    // A mobile robot's head camera patrolling rooms (SkiMap++'s own setting): objects on
    // tables and on the floor seen from 1.5-3.5 m, the training orbits as sk's (0.6-0.8 m).
    // Rooms: name, width, depth, height, tables, shelves, clutter, objects, distractors,
    // objects on the floor.
    return Preset{12,
                  {{{"apartment", 7.0f, 6.0f, 2.6f, 2, 1, 2, 8, 5, 2}, TK::kPatrol, 0.4, 1.3f},
                   {{"office", 8.0f, 6.5f, 2.8f, 3, 2, 3, 9, 5, 2}, TK::kPatrol, 0.5, 1.45f},
                   {{"lab", 6.5f, 5.5f, 2.7f, 2, 1, 2, 8, 4, 1}, TK::kPatrol, 0.3, 1.15f},
                   {{"hall", 9.0f, 6.0f, 3.0f, 3, 1, 4, 9, 6, 3}, TK::kPatrol, 0.45, 1.25f}},
                  900,
                  {10, 35, 60},
                  36};
  }
  return absl::InvalidArgumentError(
      absl::StrCat("unknown preset \"", name, "\" (mini, sk, robot)"));
}

std::string Id6(int id) {
  char b[16];
  std::snprintf(b, sizeof(b), "%06d", id);
  return b;
}

absl::Status WriteRoot(const GeneratorOptions& o, const dataset::CameraInfo& cam,
                       const std::vector<ObjectModel>& objects) {
  std::error_code ec;
  fs::create_directories(o.out_dir + "/models", ec);
  if (ec) return absl::InternalError(absl::StrCat(o.out_dir, "/models: ", ec.message()));
  if (auto s = dataset::WriteBopCamera(o.out_dir + "/camera.json", cam); !s.ok()) return s;
  std::map<int, dataset::ModelInfo> infos;
  nlohmann::ordered_json names;
  for (const ObjectModel& m : objects) {
    const Eigen::AlignedBox3f b = m.mesh.Bounds();
    infos[m.obj_id] = {m.obj_id, m.mesh.Diameter(), b.min().cast<double>(),
                       b.sizes().cast<double>(), ""};
    names[std::to_string(m.obj_id)] = m.name;
    const std::string ply = o.out_dir + "/models/obj_" + Id6(m.obj_id) + ".ply";
    if (auto s = WritePlyMm(m.mesh, ply); !s.ok()) return s;
    // The textured model as a user would have it (`skimap objects add`).
    const std::string obj = o.out_dir + "/models/textured/obj_" + Id6(m.obj_id) + ".obj";
    fs::create_directories(o.out_dir + "/models/textured", ec);
    if (auto s = WriteObj(m.mesh, obj); !s.ok()) return s;
  }
  if (auto s = dataset::WriteModelsInfo(o.out_dir + "/models/models_info.json", infos); !s.ok()) {
    return s;
  }
  nlohmann::ordered_json info = {
      {"generator", "skimap-sim"},    {"preset", o.preset}, {"seed", o.seed},
      {"depth_noise", o.depth_noise}, {"noise", o.noise},   {"motion_blur", o.motion_blur},
      {"speed_scale", o.speed_scale}};
  if (auto s = dataset::internal::WriteTextFile(o.out_dir + "/objects.json", names.dump(1) + "\n");
      !s.ok()) {
    return s;
  }
  return dataset::internal::WriteTextFile(o.out_dir + "/dataset_info.json", info.dump(1) + "\n");
}

// The plain training environment: a 1 m square support at 0.75 m in an empty 6 m room.
SceneLayout TrainingLayout() {
  SceneLayout s;
  s.spec = {"training", 6, 6, 2.6f, 0, 0, 0, 0, 0};
  s.boxes = {{"floor", "floor", {0, 0, -0.05f}, {6.2f, 6.2f, 0.1f}},
             {"support", "table_top", {0, 0, 0.375f}, {1.0f, 1.0f, 0.75f}},
             {"wall_north", "wall", {0, 3.05f, 1.3f}, {6.2f, 0.1f, 2.6f}},
             {"wall_south", "wall", {0, -3.05f, 1.3f}, {6.2f, 0.1f, 2.6f}},
             {"wall_east", "wall", {3.05f, 0, 1.3f}, {0.1f, 6.0f, 2.6f}},
             {"wall_west", "wall", {-3.05f, 0, 1.3f}, {0.1f, 6.0f, 2.6f}}};
  return s;
}

// The held-out sensor ("harsh", test scenes only; thresholds are never chosen on it): a
// worn structured-light sensor in a dim room. Depth noise 1.7 times the Kinect model's,
// range 4 m, coarser disparity (1/6 px), more dropouts at edges, grazing angles and at
// random; colour noise 4 grey levels; auto-exposure drifting +-20 % over 5 s with 3 %
// frame-to-frame jitter. spec.noise.enabled is kept (--no-depth-noise still wins).
void ApplyHarshSensor(SequenceSpec& spec) {
  DepthNoise& n = spec.noise;
  n.max_range = 4.0f;
  n.axial_a = 0.002f;
  n.axial_b = 0.0032f;
  n.subpixel = 6;
  n.edge_jump = 0.03f;
  n.edge_drop = 0.85f;
  n.grazing_cos = 0.25f;
  n.random_drop = 0.01f;
  spec.colour_noise = 4.0f;
  spec.exposure_drift = 0.2f;
  spec.exposure_jitter = 0.03f;
}

// The time-of-flight sensor ("tof", test scenes only; Kinect v2 / Azure Kinect class): no
// disparity quantisation, axial noise 1.5 mm + 0.8 mm·(z − 0.4)², range 0.5-4.5 m, and at
// depth edges (a jump > 3 cm) mixed pixels: of the edge pixels, 20 % are dropped and 60 % of
// the rest take a depth between the foreground's and the background's (flying pixels).
void ApplyTimeOfFlightSensor(SequenceSpec& spec) {
  DepthNoise& n = spec.noise;
  n.min_range = 0.5f;
  n.axial_a = 0.0015f;
  n.axial_b = 0.0008f;
  n.subpixel = 0;
  n.edge_jump = 0.03f;
  n.edge_drop = 0.2f;
  n.edge_mix = 0.6f;
}

}  // namespace

absl::StatusOr<GeneratorStats> Generate(const GeneratorOptions& o) {
  const auto start = std::chrono::steady_clock::now();
  absl::StatusOr<Preset> preset = GetPreset(o.preset);
  if (!preset.ok()) return preset.status();
  if (o.out_dir.empty()) return absl::InvalidArgumentError("--out is required");
  if (o.motion_blur < 0 || o.speed_scale <= 0 || o.threads < 1) {
    return absl::InvalidArgumentError("motion_blur >= 0, speed_scale > 0, threads >= 1 required");
  }
  if (o.noise != "kinect" && o.noise != "harsh" && o.noise != "tof") {
    return absl::InvalidArgumentError(
        absl::StrCat("unknown noise model \"", o.noise, "\" (kinect, harsh, tof)"));
  }
  absl::StatusOr<std::vector<Texture>> textures = LoadTextures(o.texture_dir, 256, kSceneTextures);
  if (!textures.ok()) return textures.status();
  const std::vector<size_t> rank = RankByDetail(*textures);
  const std::vector<ObjectModel> objects = MakeDatabaseObjects(*textures, rank, preset->objects);
  const std::vector<Mesh> distractors = MakeDistractors(*textures, rank, 4);
  dataset::CameraInfo cam{{525.0, 525.0, 319.5, 239.5, 640, 480}, 0.2};
  if (auto s = WriteRoot(o, cam, objects); !s.ok()) return s;
  if (o.models_only) return GeneratorStats{};

  GeneratorStats stats;
  double render_seconds = 0;
  auto run = [&](SequenceSpec& spec) -> absl::Status {
    spec.camera = cam;
    spec.noise.enabled = o.depth_noise;
    spec.motion_blur = o.motion_blur;
    absl::StatusOr<SequenceStats> st = RenderSequence(spec, o.threads, o.progress);
    if (!st.ok()) return st.status();
    stats.frames += st->frames;
    render_seconds += st->render_seconds;
    return absl::OkStatus();
  };

  if (o.train) {  // training orbits, one folder per object
    const SceneLayout env = TrainingLayout();
    const Mesh env_mesh = BuildStructureMesh(env, *textures);
    const int per_variant = o.train_frames > 0 ? o.train_frames : preset->train_frames;
    for (const ObjectModel& m : objects) {
      std::mt19937_64 rng(o.seed * 1000003 + m.obj_id);
      SequenceSpec spec;
      spec.dir = o.out_dir + "/train/" + Id6(m.obj_id);
      spec.label = "train/" + Id6(m.obj_id);
      spec.seed = o.seed * 7777 + m.obj_id;
      spec.light = RandomLighting(rng);
      Instance obj{&m.mesh, Eigen::Isometry3f::Identity(), 1};
      obj.T_wm.translation() = Eigen::Vector3f(0, 0, 0.75f - m.mesh.Bounds().min().z());
      spec.instances = {{&env_mesh, Eigen::Isometry3f::Identity(), 0}, obj};
      spec.annotated = {1};
      spec.obj_ids = {m.obj_id};
      const float radius = std::max(0.6f, 2.8f * m.mesh.Diameter());
      nlohmann::ordered_json variants = nlohmann::ordered_json::array();
      for (float elev : preset->train_elevations) {
        const int first = static_cast<int>(spec.poses.size());
        for (const auto& T : MakeTrainingOrbit(obj.T_wm.translation(), radius, elev,
                                               Uniform(rng, 0, 360), per_variant)) {
          spec.poses.push_back(T);
        }
        variants.push_back({{"elevation_deg", elev},
                            {"radius_m", radius},
                            {"first_id", first},
                            {"count", per_variant}});
      }
      if (auto s = run(spec); !s.ok()) return s;
      if (auto s = dataset::internal::WriteTextFile(spec.dir + "/variants.json",
                                                    variants.dump(1) + "\n");
          !s.ok()) {
        return s;
      }
    }
  }

  const int num_scenes = o.scenes >= 0 ? std::min<int>(o.scenes, preset->scenes.size())
                                       : static_cast<int>(preset->scenes.size());
  for (int k = 0; k < num_scenes; ++k) {
    const SceneSpec& sc = preset->scenes[k];
    std::mt19937_64 rng(o.seed * 2654435761ull + 17 * (k + 1));
    const SceneLayout layout = MakeRoom(sc.room, objects, distractors, rng);
    const Mesh structure = BuildStructureMesh(layout, *textures);
    SequenceSpec spec;
    spec.dir = o.out_dir + "/test/" + Id6(k + 1);
    spec.label = "test/" + Id6(k + 1) + " (" + sc.room.name + ")";
    spec.seed = o.seed * 31337 + k;
    spec.light = RandomLighting(rng);
    if (o.noise == "harsh") ApplyHarshSensor(spec);
    if (o.noise == "tof") ApplyTimeOfFlightSensor(spec);
    spec.instances.push_back({&structure, Eigen::Isometry3f::Identity(), 0});
    for (const Placement& p : layout.objects) {
      spec.annotated.push_back(static_cast<int>(spec.instances.size()));
      spec.obj_ids.push_back(p.obj_id);
      spec.instances.push_back(
          {&objects[p.mesh_index].mesh, p.T_wm, static_cast<uint16_t>(spec.annotated.size())});
    }
    for (const Placement& p : layout.distractors) {
      spec.instances.push_back({&distractors[p.mesh_index], p.T_wm, 0});
    }
    TrajectoryOptions traj;
    traj.kind = sc.trajectory;
    traj.frames = o.scene_frames > 0 ? o.scene_frames : preset->scene_frames;
    traj.speed = sc.speed * o.speed_scale;
    traj.seed = o.seed + k;
    traj.height = sc.height;
    spec.poses = MakeTrajectory(layout, traj);
    if (auto s = run(spec); !s.ok()) return s;
    if (auto s = WriteSceneGeometry(layout, objects, spec.dir + "/scene_geometry.json"); !s.ok()) {
      return s;
    }
  }
  stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  stats.render_fps = render_seconds > 0 ? stats.frames / render_seconds * o.threads : 0;
  return stats;
}

}  // namespace skimap::sim
