#include "server/core/recognition/instance_reconciler.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <vector>

#include "absl/container/flat_hash_set.h"
#include "absl/strings/str_cat.h"
#include "perception/recognition/instance_estimator.h"
#include "server/core/recognition/instance_proto.h"

namespace skimap::server {
namespace {

using recognition::HypothesisSample;
using recognition::InstanceEstimate;
using recognition::LabelMatch;

constexpr float kMinEstimateScore = 3;  // inlier label weight of an estimate worth keeping

Eigen::Vector3f PositionOf(const Instance& i) { return {i.t[0], i.t[1], i.t[2]}; }
Point3 ToPoint(const Eigen::Vector3f& p) { return {p.x(), p.y(), p.z()}; }
Eigen::Vector3f FromPoint(const Point3& p) { return Eigen::Vector3f(p.x, p.y, p.z); }

// Half the diagonal of a voxel: what a search by voxel centre adds to reach every item.
double HalfDiagonal(const Grid& g) { return 0.5 * std::sqrt(3.0) * g.resolution(); }

std::vector<HypothesisSample> HypothesesNear(const HypothesesVolume& v, uint32_t obj_id,
                                             const Eigen::Vector3f& c, float radius) {
  std::vector<HypothesisSample> out;
  v.RadiusSearch(
      ToPoint(c), radius + HalfDiagonal(v.grid()),
      [&](const VoxelKey&, const HypothesesVoxel& voxel) {
        for (const Hypothesis& h : voxel.items()) {
          const Eigen::Vector3f t(h.t[0], h.t[1], h.t[2]);
          if (h.object_id != obj_id || (t - c).norm() > radius) continue;
          out.push_back({t, Eigen::Quaternionf(h.q[0], h.q[1], h.q[2], h.q[3]), h.score, h.frame});
        }
      });
  return out;
}

std::vector<LabelMatch> MatchesNear(const LabelsVolume& labels,
                                    const recognition::RecognitionModel& model, int object_index,
                                    const Eigen::Vector3f& c, float radius) {
  std::vector<LabelMatch> out;
  const Grid& g = labels.grid();
  labels.RadiusSearch(ToPoint(c), radius, [&](const VoxelKey& k, const MultiLabelVoxel& voxel) {
    const Eigen::Vector3f p = FromPoint(g.Center(k));
    for (const MultiLabelVoxel::Entry& e : voxel.entries()) {
      Eigen::Vector3f v;
      int o;
      if (model.ClassPoint(e.label, &v, &o) && o == object_index) {
        out.push_back({p, v, static_cast<float>(e.count)});
      }
    }
  });
  return out;
}

// The pose of an instance as a transform (world <- model).
Eigen::Isometry3f PoseOf(const Instance& i) {
  Eigen::Isometry3f pose = Eigen::Isometry3f::Identity();
  pose.linear() =
      Eigen::Quaternionf(i.q[0], i.q[1], i.q[2], i.q[3]).normalized().toRotationMatrix();
  pose.translation() = Eigen::Vector3f(i.t[0], i.t[1], i.t[2]);
  return pose;
}

struct Existing {
  Instance instance;
  bool matched = false;
  bool supported = false;  // a hypothesis of the object lies within the match distance
};

class Reconciler {
 public:
  Reconciler(const recognition::RecognitionModel& model, const ReconcileParams& params,
             const ReconcileRequest& request, MapState* state)
      : model_(model), params_(params), request_(request), state_(*state) {}

  int Run() {
    const recognition::ObjectShape& shape = model_.object(request_.object_index);
    const uint32_t obj_id = static_cast<uint32_t>(shape.obj_id);
    const float d = std::max(shape.radius, 0.03f);
    const Eigen::Vector3f c = request_.region.centre;
    const float reach = request_.region.radius + shape.radius + d;
    const std::vector<HypothesisSample> hyps = HypothesesNear(state_.hypotheses, obj_id, c, reach);
    std::vector<InstanceEstimate> estimates =
        recognition::EstimateInstances(hyps, {.radius = std::max(0.3f * shape.radius, 0.03f)});
    Refine(shape, &estimates);

    // Instances of other objects around: a stronger one in the same space rules this one out.
    struct Other {
      int index;
      Eigen::Isometry3f pose;
      float score;
    };
    std::vector<Other> others;
    state_.instances.RadiusSearch(ToPoint(c), reach + 0.5 + HalfDiagonal(state_.instances.grid()),
                                  [&](const VoxelKey&, const InstancesVoxel& voxel) {
                                    for (const Instance& i : voxel.items()) {
                                      const int index =
                                          model_.FindObject(static_cast<int>(i.object_id));
                                      if (i.object_id != obj_id && index >= 0 && Visible(i)) {
                                        others.push_back({index, PoseOf(i), i.score});
                                      }
                                    }
                                  });
    auto ruled_out = [&](const Eigen::Isometry3f& pose, float score) {
      return std::any_of(others.begin(), others.end(), [&](const Other& o) {
        return o.score > score && Overlap(shape, pose, model_.object(o.index), o.pose);
      });
    };
    std::erase_if(estimates, [&](const InstanceEstimate& e) {
      Eigen::Isometry3f pose = Eigen::Isometry3f::Identity();
      pose.linear() = e.q.toRotationMatrix();
      pose.translation() = e.t;
      return ruled_out(pose, e.score);
    });

    std::vector<Existing> existing;
    state_.instances.RadiusSearch(
        ToPoint(c), reach + HalfDiagonal(state_.instances.grid()),
        [&](const VoxelKey&, const InstancesVoxel& voxel) {
          for (const Instance& i : voxel.items()) {
            if (i.object_id == obj_id && (PositionOf(i) - c).norm() <= reach) {
              existing.push_back({i});
            }
          }
        });
    for (Existing& e : existing) {
      e.supported = std::any_of(hyps.begin(), hyps.end(), [&](const HypothesisSample& h) {
        return (h.t - PositionOf(e.instance)).norm() <= d;
      });
    }
    std::sort(existing.begin(), existing.end(),
              [](const Existing& a, const Existing& b) { return a.instance.id < b.instance.id; });

    // Estimates to instances, strongest first: the nearest unmatched instance within d.
    std::vector<const InstanceEstimate*> unmatched;
    for (const InstanceEstimate& e : estimates) {
      Existing* best = Nearest(existing, e.t, d, [](const Existing& x) { return !x.matched; });
      if (best == nullptr) {
        unmatched.push_back(&e);
        continue;
      }
      best->matched = true;
      Update(best->instance, e, obj_id);
    }
    for (const InstanceEstimate* e : unmatched) {
      const bool duplicate =
          Nearest(existing, e->t, d, [](const Existing& x) { return x.matched; }) != nullptr;
      if (duplicate) continue;
      // An instance that lost its support moved here (UpdatePoses): it keeps its id.
      Existing* moved = Nearest(existing, e->t, std::numeric_limits<float>::max(),
                                [](const Existing& x) { return !x.matched && !x.supported; });
      if (moved != nullptr) {
        moved->matched = true;
        Update(moved->instance, *e, obj_id);
      } else {
        Instance fresh;
        fresh.id = state_.recognition.next_instance_id++;
        state_.recognition.meta_dirty = true;
        fresh.object_id = obj_id;
        fresh.first_frame = request_.frame;
        fresh.first_time_us = request_.frame_time_us;
        existing.push_back({fresh, true, true});
        Update(existing.back().instance, *e, obj_id);
      }
    }
    for (Existing& e : existing) {
      const bool unsupported = !e.matched && !e.supported &&
                               (PositionOf(e.instance) - c).norm() <= request_.region.radius;
      if (e.instance.id != 0 && (unsupported || ruled_out(PoseOf(e.instance), e.instance.score))) {
        Remove(e.instance, v1::InstanceEvent::REMOVED, 0);
        e.instance.id = 0;
      }
    }
    AddNeighbours(obj_id, d, &existing);
    MergeDuplicates(&existing, d);
    return events_;
  }

 private:
  template <class Pred>
  static Existing* Nearest(std::vector<Existing>& existing, const Eigen::Vector3f& t, float within,
                           Pred pred) {
    Existing* best = nullptr;
    float best_d = within;
    for (Existing& x : existing) {
      if (x.instance.id == 0 || !pred(x)) continue;
      const float dist = (PositionOf(x.instance) - t).norm();
      if (dist <= best_d) {
        best_d = dist;
        best = &x;
      }
    }
    return best;
  }

  // Refines each estimate against the labels; drops those without enough label support.
  void Refine(const recognition::ObjectShape& shape, std::vector<InstanceEstimate>* estimates) {
    std::vector<InstanceEstimate> kept;
    for (InstanceEstimate e : *estimates) {
      Eigen::Isometry3f pose = Eigen::Isometry3f::Identity();
      pose.linear() = e.q.toRotationMatrix();
      pose.translation() = e.t;
      const std::vector<LabelMatch> matches =
          MatchesNear(state_.labels, model_, request_.object_index, pose * shape.centre,
                      shape.radius + params_.inlier_distance);
      const recognition::PoseEstimate refined =
          recognition::RefinePose(matches, pose, params_.inlier_distance);
      if (refined.score < kMinEstimateScore) continue;
      e.t = refined.pose.translation();
      e.q = Eigen::Quaternionf(refined.pose.linear()).normalized();
      e.score = refined.score;
      const SurfaceFit fit = FitSurface(state_.rgb, shape, refined.pose);
      e.fit = fit.observed * fit.colour;
      kept.push_back(e);
    }
    *estimates = std::move(kept);
  }

  bool Visible(const Instance& i) const {
    return i.id != 0 && IsVisible(params_.visible, i, &model_);
  }

  void Update(Instance& inst, const InstanceEstimate& e, uint32_t obj_id) {
    const Instance before = inst;
    inst.object_id = obj_id;
    inst.t = {e.t.x(), e.t.y(), e.t.z()};
    inst.q = {e.q.w(), e.q.x(), e.q.y(), e.q.z()};
    inst.score = e.score;
    inst.support = static_cast<uint32_t>(e.support);
    inst.frames = static_cast<uint32_t>(e.frames);
    inst.spread_t = e.spread_t;
    inst.spread_r = e.spread_r;
    inst.fit = e.fit;
    if (!request_.views.empty()) {
      inst.view_agree = 0;
      inst.view_conflict = 0;
      for (const ViewFrame& view : request_.views) {
        CountView(model_.object(request_.object_index), PoseOf(inst), view, &inst.view_agree,
                  &inst.view_conflict);
      }
    }
    if (request_.frame_supports && e.last_frame == request_.frame) {
      inst.last_frame = request_.frame;
      inst.last_time_us = request_.frame_time_us;
    } else if (inst.last_frame == 0) {
      inst.last_frame = e.last_frame;
    }
    Put(inst);
    Transition(before, inst);
  }

  // Emits what `before` -> `after` means to a client that sees visible instances only:
  // CREATED, REMOVED, or UPDATED (any field changed: replaying the events gives exactly
  // what ListInstances answers). A `before` without support is a new instance.
  void Transition(const Instance& before, const Instance& after) {
    const bool was_visible = before.support > 0 && Visible(before);
    const bool visible = Visible(after);
    if (visible && !was_visible) {
      Emit(v1::InstanceEvent::CREATED, after, 0);
    } else if (!visible && was_visible) {
      Emit(v1::InstanceEvent::REMOVED, after, 0);
    } else if (visible && !(after == before)) {
      Emit(v1::InstanceEvent::UPDATED, after, 0);
    }
  }

  // x is the better estimate of one object than y: visible first, then the higher score.
  bool Better(const Instance& x, const Instance& y) const {
    if (Visible(x) != Visible(y)) return Visible(x);
    return x.score > y.score;
  }

  // An instance updated here may have moved (by up to d) next to an instance of the object
  // that lies beyond the region's reach and so is not in `existing`: those are added (as
  // supported, so nothing but a merge can remove them), and `existing` sorted by id again.
  void AddNeighbours(uint32_t obj_id, float d, std::vector<Existing>* existing) {
    absl::flat_hash_set<uint64_t> known;
    for (const Existing& e : *existing) known.insert(e.instance.id);
    std::vector<Existing> found;
    for (const Existing& e : *existing) {
      if (e.instance.id == 0 || !e.matched) continue;
      state_.instances.RadiusSearch(ToPoint(PositionOf(e.instance)),
                                    d + HalfDiagonal(state_.instances.grid()),
                                    [&](const VoxelKey&, const InstancesVoxel& voxel) {
                                      for (const Instance& i : voxel.items()) {
                                        if (i.object_id == obj_id && known.insert(i.id).second) {
                                          found.push_back({i, false, true});
                                        }
                                      }
                                    });
    }
    if (found.empty()) return;
    existing->insert(existing->end(), found.begin(), found.end());
    std::sort(existing->begin(), existing->end(),
              [](const Existing& a, const Existing& b) { return a.instance.id < b.instance.id; });
  }

  void MergeDuplicates(std::vector<Existing>* existing, float d) {
    for (size_t a = 0; a < existing->size(); ++a) {  // sorted by id, new ones last
      Instance& older = (*existing)[a].instance;
      if (older.id == 0) continue;
      for (size_t b = a + 1; b < existing->size(); ++b) {
        Instance& younger = (*existing)[b].instance;
        if (younger.id == 0 || (PositionOf(younger) - PositionOf(older)).norm() > d) continue;
        const Instance before = older;
        if (Better(younger, older)) {  // the better estimate wins, the older id stays
          older = younger;
          older.id = before.id;
          older.first_frame = before.first_frame;
          older.first_time_us = before.first_time_us;
        }
        if (!(older == before)) {
          Put(older);
          Transition(before, older);
        }
        Remove(younger, v1::InstanceEvent::MERGED, older.id);
        younger.id = 0;
      }
    }
  }

  void Put(const Instance& inst) {
    Drop(inst.id);
    VoxelKey key;
    if (!state_.instances.grid().ToKey(inst.t[0], inst.t[1], inst.t[2], &key)) return;
    state_.instances.IntegrateKey(key, InstancesVoxel(inst));
    state_.dirty_instances.insert(ChunkOf(key));
    state_.recognition.instance_keys[inst.id] = key;
  }

  void Drop(uint64_t id) {
    auto it = state_.recognition.instance_keys.find(id);
    if (it == state_.recognition.instance_keys.end()) return;
    Instance key_only;
    key_only.id = id;
    state_.instances.DeintegrateKey(it->second, InstancesVoxel(key_only));
    state_.dirty_instances.insert(ChunkOf(it->second));
    state_.recognition.instance_keys.erase(it);
  }

  void Remove(const Instance& inst, v1::InstanceEvent::Type type, uint64_t merged_into) {
    if (Visible(inst)) Emit(type, inst, merged_into);
    Drop(inst.id);
  }

  void Emit(v1::InstanceEvent::Type type, const Instance& inst, uint64_t merged_into) {
    v1::InstanceEvent e;
    e.set_type(type);
    *e.mutable_instance() = ToProto(inst, &model_, params_.map_id);
    e.set_merged_into(merged_into);
    e.set_frame_sequence(request_.frame);
    state_.recognition.log.Append(std::move(e));
    state_.recognition.meta_dirty = true;
    ++events_;
  }

  const recognition::RecognitionModel& model_;
  const ReconcileParams& params_;
  const ReconcileRequest& request_;
  MapState& state_;
  int events_ = 0;
};

}  // namespace

int ReconcileInstances(const recognition::RecognitionModel& model, const ReconcileParams& params,
                       const ReconcileRequest& request, MapState* state) {
  return Reconciler(model, params, request, state).Run();
}

InstanceVisibility ResolveVisibility(const VisibilityOptions& options,
                                     const recognition::RecognitionModel* model) {
  return options.Resolve(model == nullptr ? nullptr : &model->db().params().instances);
}

bool IsVisible(const InstanceVisibility& visible, const Instance& instance,
               const recognition::RecognitionModel* model) {
  const int index = model == nullptr ? -1 : model->FindObject(static_cast<int>(instance.object_id));
  return visible(instance, index < 0 ? 0.0 : model->object(index).surface_area);
}

}  // namespace skimap::server
