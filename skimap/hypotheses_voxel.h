// HypothesesVoxel and InstancesVoxel: sets of object poses stored at their position.
//
// SkiMap++ §4.2-4.3: a hypothesis is (t, R, object) with a score from the Hough vote; the
// map keys it by its translation t and keeps the orientation as is. An instance is the
// refined result of clustering hypotheses, with a stable id.
//
// Poses are in the map frame: t in metres, R as a unit quaternion (w, x, y, z).
//  - HypothesesVoxel is a set: += adds the hypotheses not already present (exact
//    equality), -= removes the equal ones. Weight() is the summed score.
//  - InstancesVoxel is keyed by instance id: += inserts or replaces by id (the newest
//    estimate wins), -= removes the ids present in the operand. Weight() is the count.
#ifndef SKIMAP_HYPOTHESES_VOXEL_H_
#define SKIMAP_HYPOTHESES_VOXEL_H_

#include <array>
#include <cstdint>
#include <vector>

#include "base/encoding.h"

namespace skimap {

struct Hypothesis {
  std::array<float, 3> t{};            // metres, map frame
  std::array<float, 4> q{1, 0, 0, 0};  // w, x, y, z
  uint32_t object_id = 0;
  float score = 0;
  uint64_t frame = 0;  // sequence of the frame whose recognition produced it
  friend bool operator==(const Hypothesis&, const Hypothesis&) = default;
};

struct Instance {
  uint64_t id = 0;
  uint32_t object_id = 0;
  std::array<float, 3> t{};
  std::array<float, 4> q{1, 0, 0, 0};
  float score = 0;
  uint32_t support = 0;                         // number of hypotheses behind this estimate
  uint32_t frames = 0;                          // distinct frames those hypotheses came from
  uint64_t first_frame = 0, last_frame = 0;     // sequences: created, last supported
  int64_t first_time_us = 0, last_time_us = 0;  // those frames' timestamps (unix µs)
  float spread_t = 0;  // RMS distance of the supporting hypotheses to t, metres
  float spread_r = 0;  // RMS angle of their rotations to q, radians
  float fit = 0;       // agreement with the map's surface and colour, 0..1
  // View consistency at the pose, over the map's keyframes when the instance was last
  // updated (server/core/recognition/view_keyframes.h): its surface points that agreed with a
  // frame's depth, and those in front of it (space the camera saw through).
  uint32_t view_agree = 0, view_conflict = 0;
  friend bool operator==(const Instance&, const Instance&) = default;
};

// view_conflict / (view_agree + view_conflict), 0 without view evidence.
inline float ViewConflict(const Instance& i) {
  const uint64_t n = uint64_t{i.view_agree} + i.view_conflict;
  return n == 0 ? 0.0f : static_cast<float>(i.view_conflict) / static_cast<float>(n);
}

class HypothesesVoxel {
 public:
  static constexpr uint32_t kTypeId = 4;
  HypothesesVoxel() = default;
  explicit HypothesesVoxel(const Hypothesis& h) : items_{h} {}

  HypothesesVoxel& operator+=(const HypothesesVoxel& o);
  HypothesesVoxel& operator-=(const HypothesesVoxel& o);
  const std::vector<Hypothesis>& items() const { return items_; }

  bool IsEmpty() const { return items_.empty(); }
  float Weight() const;
  size_t HeapBytes() const { return items_.capacity() * sizeof(Hypothesis); }
  void Encode(Encoder& e) const;
  static bool Decode(Decoder& d, HypothesesVoxel* v);
  friend bool operator==(const HypothesesVoxel&, const HypothesesVoxel&) = default;

 private:
  std::vector<Hypothesis> items_;
};

class InstancesVoxel {
 public:
  static constexpr uint32_t kTypeId = 5;
  InstancesVoxel() = default;
  explicit InstancesVoxel(const Instance& i) : items_{i} {}

  InstancesVoxel& operator+=(const InstancesVoxel& o);
  InstancesVoxel& operator-=(const InstancesVoxel& o);
  const std::vector<Instance>& items() const { return items_; }

  bool IsEmpty() const { return items_.empty(); }
  float Weight() const { return static_cast<float>(items_.size()); }
  size_t HeapBytes() const { return items_.capacity() * sizeof(Instance); }
  void Encode(Encoder& e) const;
  // Rejects duplicate ids.
  static bool Decode(Decoder& d, InstancesVoxel* v);
  friend bool operator==(const InstancesVoxel&, const InstancesVoxel&) = default;

 private:
  std::vector<Instance> items_;
};

}  // namespace skimap

#endif  // SKIMAP_HYPOTHESES_VOXEL_H_
