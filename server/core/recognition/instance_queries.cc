// InstanceQueries: instances found by recognition (instances.proto; docs/recognition.md).
#include "server/core/recognition/instance_queries.h"

#include <algorithm>
#include <cmath>

#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "base/echo.h"
#include "base/encoding.h"
#include "server/core/common/page_token.h"
#include "server/core/maps/map_service.h"
#include "server/core/recognition/instance_proto.h"
#include "server/core/recognition/instance_reconciler.h"

namespace skimap::server {
namespace {

constexpr int kDefaultPageSize = 100;
constexpr int kMaxPageSize = 1000;

absl::Status NoRecognition(const LiveMap& map) {
  return absl::FailedPreconditionError(
      absl::StrCat("map ", MapName(map.id()),
                   " has no recognition (create it with options.recognition.enabled)"));
}

bool Finite(const v1::Vec3& v) {
  return std::isfinite(v.x()) && std::isfinite(v.y()) && std::isfinite(v.z());
}

// The region test of a ListInstances request; InvalidArgument naming the field.
absl::StatusOr<std::function<bool(const Instance&)>> RegionFilter(
    const v1::ListInstancesRequest& r) {
  switch (r.region_case()) {
    case v1::ListInstancesRequest::kBox: {
      const v1::Box3& b = r.box();
      if (!Finite(b.min()) || !Finite(b.max()) || b.min().x() > b.max().x() ||
          b.min().y() > b.max().y() || b.min().z() > b.max().z()) {
        return absl::InvalidArgumentError("box: must be finite with min <= max on every axis");
      }
      return [b](const Instance& i) {
        return i.t[0] >= b.min().x() && i.t[0] <= b.max().x() && i.t[1] >= b.min().y() &&
               i.t[1] <= b.max().y() && i.t[2] >= b.min().z() && i.t[2] <= b.max().z();
      };
    }
    case v1::ListInstancesRequest::kSphere: {
      const v1::Sphere& s = r.sphere();
      if (!Finite(s.center()) || !(s.radius() > 0) || !std::isfinite(s.radius())) {
        return absl::InvalidArgumentError(
            "sphere: center must be finite and radius finite and > 0");
      }
      return [s](const Instance& i) {
        const double dx = i.t[0] - s.center().x(), dy = i.t[1] - s.center().y(),
                     dz = i.t[2] - s.center().z();
        return dx * dx + dy * dy + dz * dz <= s.radius() * s.radius();
      };
    }
    default:
      return [](const Instance&) { return true; };
  }
}

// What a ListInstances page depends on but its position (page tokens).
uint32_t InstanceQueryFingerprint(const LiveMap& map, const v1::ListInstancesRequest& r) {
  v1::ListInstancesRequest filters = r;
  filters.clear_page_size();
  filters.clear_page_token();
  filters.clear_map();
  std::string bytes;
  (void)filters.SerializeToString(&bytes);  // deterministic for these fields
  return QueryFingerprint(map.incarnation(), "ListInstances", bytes);
}

}  // namespace

absl::StatusOr<v1::ListInstancesResponse> InstanceQueries::ListInstances(
    const v1::ListInstancesRequest& request) const {
  absl::StatusOr<std::shared_ptr<LiveMap>> map = maps_->FindMap(request.map(), "map");
  if (!map.ok()) return map.status();
  const LiveMap& m = **map;
  if (!m.config().recognition.enabled) return NoRecognition(m);
  if (request.page_size() < 0 || request.page_size() > kMaxPageSize) {
    return absl::InvalidArgumentError(absl::StrCat("page_size: must be in 0..", kMaxPageSize));
  }
  if (!(request.min_score() >= 0) || !std::isfinite(request.min_score())) {
    return absl::InvalidArgumentError("min_score: must be finite and >= 0");
  }
  for (int i = 0; i < request.obj_ids_size(); ++i) {
    if (request.obj_ids(i) <= 0) {
      return absl::InvalidArgumentError(
          absl::StrCat("obj_ids[", i, "]: must be a positive object id"));
    }
  }
  absl::StatusOr<std::function<bool(const Instance&)>> in_region = RegionFilter(request);
  if (!in_region.ok()) return in_region.status();
  const uint32_t query = InstanceQueryFingerprint(m, request);
  uint64_t after = 0;
  if (!request.page_token().empty()) {
    absl::StatusOr<std::string> position = DecodePageToken(request.page_token(), query);
    if (!position.ok()) return position.status();
    Decoder d(*position);
    if (!d.U64(&after) || d.remaining() != 0) {
      return absl::InvalidArgumentError("page_token: malformed");
    }
  }
  const size_t limit = request.page_size() == 0 ? kDefaultPageSize : request.page_size();
  const InstanceVisibility visible =
      ResolveVisibility(m.config().recognition.visible, m.recognition_model());
  const std::vector<int32_t> objects(request.obj_ids().begin(), request.obj_ids().end());
  v1::ListInstancesResponse response;
  std::vector<Instance> found;
  m.Read([&](const MapState& s) {
    response.set_event_sequence(s.recognition.log.last_sequence());
    s.instances.ForEach([&](const VoxelKey&, const InstancesVoxel& voxel) {
      for (const Instance& i : voxel.items()) {
        if (i.id <= after || i.score < request.min_score() ||
            !IsVisible(visible, i, m.recognition_model()) || !(*in_region)(i)) {
          continue;
        }
        if (!objects.empty() && std::find(objects.begin(), objects.end(),
                                          static_cast<int32_t>(i.object_id)) == objects.end()) {
          continue;
        }
        found.push_back(i);
      }
    });
    return 0;
  });
  std::sort(found.begin(), found.end(),
            [](const Instance& a, const Instance& b) { return a.id < b.id; });
  for (size_t k = 0; k < found.size() && k < limit; ++k) {
    *response.add_instances() = ToProto(found[k], m.recognition_model(), m.id());
  }
  if (found.size() > limit) {
    std::string position;
    Encoder e(&position);
    e.U64(found[limit - 1].id);
    response.set_next_page_token(EncodePageToken(query, position));
  }
  return response;
}

absl::StatusOr<v1::Instance> InstanceQueries::GetInstance(
    const v1::GetInstanceRequest& request) const {
  // "maps/{map}/instances/{id}"
  const std::string& name = request.name();
  const size_t slash = name.find("/instances/");
  uint64_t id = 0;
  if (slash == std::string::npos ||
      !absl::SimpleAtoi(absl::string_view(name).substr(slash + 11), &id) || id == 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("name: must be \"maps/{map_id}/instances/{instance_id}\", got ", Echo(name)));
  }
  absl::StatusOr<std::shared_ptr<LiveMap>> map = maps_->FindMap(name.substr(0, slash), "name");
  if (!map.ok()) return map.status();
  const LiveMap& m = **map;
  if (!m.config().recognition.enabled) return NoRecognition(m);
  std::optional<Instance> found = m.Read([&](const MapState& s) -> std::optional<Instance> {
    auto it = s.recognition.instance_keys.find(id);
    if (it == s.recognition.instance_keys.end()) return std::nullopt;
    std::optional<InstancesVoxel> voxel = s.instances.Find(it->second);
    if (!voxel.has_value()) return std::nullopt;
    for (const Instance& i : voxel->items()) {
      if (i.id == id) return i;
    }
    return std::nullopt;
  });
  if (!found.has_value() ||
      !IsVisible(ResolveVisibility(m.config().recognition.visible, m.recognition_model()), *found,
                 m.recognition_model())) {
    return absl::NotFoundError(absl::StrCat("instance ", id, " not found in ", MapName(m.id())));
  }
  return ToProto(*found, m.recognition_model(), m.id());
}

InstanceQueries::InstanceWatch::~InstanceWatch() {
  if (watcher_ != 0) map_->RemoveInstanceWatcher(watcher_);
}

absl::StatusOr<std::vector<v1::InstanceEvent>> InstanceQueries::InstanceWatch::Next(size_t max) {
  if (!map_->Refused().ok()) {
    return absl::NotFoundError(
        absl::StrCat("map ", MapName(map_->id()), " was deleted or unloaded"));
  }
  std::vector<v1::InstanceEvent> events;
  absl::Status s = map_->Read(
      [&](const MapState& state) { return state.recognition.log.After(after_, max, &events); });
  if (!s.ok()) return s;
  if (!events.empty()) after_ = events.back().sequence();
  return events;
}

absl::StatusOr<std::unique_ptr<InstanceQueries::InstanceWatch>> InstanceQueries::WatchInstances(
    const v1::WatchInstancesRequest& request, std::function<void()> wake) const {
  absl::StatusOr<std::shared_ptr<LiveMap>> map = maps_->FindMap(request.map(), "map");
  if (!map.ok()) return map.status();
  if (!(*map)->config().recognition.enabled) return NoRecognition(**map);
  std::unique_ptr<InstanceWatch> watch(new InstanceWatch(*map, request.after_sequence()));
  // Fails early when the events asked for are gone.
  std::vector<v1::InstanceEvent> none;
  absl::Status s = (*map)->Read(
      [&](const MapState& state) { return state.recognition.log.After(watch->after_, 0, &none); });
  if (!s.ok()) return s;
  watch->watcher_ = (*map)->AddInstanceWatcher(std::move(wake));
  return watch;
}

}  // namespace skimap::server
