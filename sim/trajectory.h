// Camera trajectories at a fixed frame rate: hand-held orbits around a table, hand-held
// sweeps along a shelf, a robot head walking a loop around the room, and the object
// training orbits. Poses are world <- camera (OpenCV camera axes).
//
// Thread safety: pure functions.
#ifndef SKIMAP_SIM_TRAJECTORY_H_
#define SKIMAP_SIM_TRAJECTORY_H_

#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "sim/scene.h"

namespace skimap::sim {

// Kinds of scene trajectory.
enum class TrajectoryKind { kOrbit, kSweep, kRobot, kTour, kPatrol };

// Parses "orbit", "sweep", "robot", "tour", "patrol". kInvalidArgument otherwise.
absl::StatusOr<TrajectoryKind> ParseTrajectoryKind(const std::string& name);
const char* TrajectoryKindName(TrajectoryKind kind);

// Parameters of a scene trajectory.
struct TrajectoryOptions {
  TrajectoryKind kind = TrajectoryKind::kOrbit;
  int frames = 300;
  double fps = 30;
  double speed = 0.35;   // m/s along the path (hand-held ~0.3, robot ~0.5)
  bool shake = true;     // hand-held tremor (1 cm, 0.7 deg); robot, patrol: head bob
  float height = 1.35f;  // robot, patrol: camera height above the floor, metres
  uint64_t seed = 1;     // phases of the tremor
};

// Camera pose looking from `eye` at `target` with world z up. REQUIRES: eye != target and
// the view direction not vertical.
Eigen::Isometry3f LookAt(const Eigen::Vector3f& eye, const Eigen::Vector3f& target);

// Poses for every frame. Orbit: around the first table (radius 1.3 m, eye 0.7 m above the
// top). Sweep: back and forth 1.1 m in front of the first shelf (orbit if there is none).
// Robot: a loop 1 m from the walls at 1.35 m height, looking around (+-35 deg yaw, 20 deg
// down). Tour: a hand-held walk from database object to database object (in the order of
// their bearing from the room centre), as someone scanning a room for objects does (SK17):
// at each, 60 % of its share of the frames sweeping a 50-degree arc 0.95 m away (0.45 m
// above it, on the room side), the rest moving on to the next; `speed` is not used.
// Patrol: a mobile robot's head camera (SkiMap++'s setting): the base drives the loop 1 m
// from the walls at `speed`, the camera `height` above the floor; the head turns towards the
// nearest support centre (table top, shelf board or floor area) 1.2-4 m away that lies less
// than 100 deg off the driving direction, tilting down to its height (10-35 deg), with a slow +-15
// deg pan scan around it; with none in reach it looks ahead and inward, 20 deg down. Head yaw and
// pitch follow their targets with a 0.8 s time constant (a head does not jump).
std::vector<Eigen::Isometry3f> MakeTrajectory(const SceneLayout& scene,
                                              const TrajectoryOptions& options);

// Training orbit around the world origin: `frames` views evenly spaced in azimuth at
// elevation `elevation_deg`, distance `radius`, looking at `target`.
std::vector<Eigen::Isometry3f> MakeTrainingOrbit(const Eigen::Vector3f& target, float radius,
                                                 float elevation_deg, float azimuth0_deg,
                                                 int frames);

}  // namespace skimap::sim

#endif  // SKIMAP_SIM_TRAJECTORY_H_
