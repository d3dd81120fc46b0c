// InstanceQueries: the Labels volume of a map with recognition (GetLabelVoxels,
// instances.proto), each voxel reduced to its heaviest label and that class's object.
#include <algorithm>
#include <optional>

#include "absl/strings/str_cat.h"
#include "base/encoding.h"
#include "server/core/common/page_token.h"
#include "server/core/maps/map_service.h"
#include "server/core/maps/query_box.h"
#include "server/core/recognition/instance_queries.h"

namespace skimap::server {
namespace {

constexpr int kDefaultPage = 10000;
constexpr int kMaxPage = 100000;

// What a page depends on but its position: this incarnation of the map, the box and
// min_count. The page size may change from page to page.
uint32_t LabelQueryFingerprint(const LiveMap& map, const v1::GetLabelVoxelsRequest& r) {
  std::string filters;
  Encoder e(&filters);
  EncodeQueryBox(r.has_box(), r.box(), e);
  e.U32(r.min_count());
  return QueryFingerprint(map.incarnation(), "GetLabelVoxels", filters);
}

// The dataset id of class `c`'s object; 0 without a model or for a class it does not use.
int32_t ObjectOf(const recognition::RecognitionModel* model, uint32_t c) {
  if (model == nullptr) return 0;
  Eigen::Vector3f point;
  int index = -1;
  if (!model->ClassPoint(c, &point, &index)) return 0;
  return model->object(index).obj_id;
}

}  // namespace

absl::StatusOr<v1::GetLabelVoxelsResponse> InstanceQueries::GetLabelVoxels(
    const v1::GetLabelVoxelsRequest& request) const {
  absl::StatusOr<std::shared_ptr<LiveMap>> map = maps_->FindMap(request.map(), "map");
  if (!map.ok()) return map.status();
  const LiveMap& m = **map;
  if (!m.config().recognition.enabled) {
    return absl::FailedPreconditionError(
        absl::StrCat("map ", MapName(m.id()),
                     " has no recognition (create it with options.recognition.enabled)"));
  }
  if (request.page_size() < 0 || request.page_size() > kMaxPage) {
    return absl::InvalidArgumentError(absl::StrCat("page_size must be in 0..", kMaxPage));
  }
  const size_t page = request.page_size() == 0 ? kDefaultPage : request.page_size();
  const uint32_t min_count = std::max<uint32_t>(request.min_count(), 1);
  const uint32_t query = LabelQueryFingerprint(m, request);
  absl::StatusOr<std::optional<uint64_t>> start =
      DecodeKeyPageToken(request.page_token(), query, "GetLabelVoxels");
  if (!start.ok()) return start.status();
  const recognition::RecognitionModel* model = m.recognition_model();
  v1::GetLabelVoxelsResponse out;
  absl::Status status = m.Read([&](const MapState& state) -> absl::Status {
    const LabelsVolume& labels = state.labels;
    const Grid& grid = labels.grid();
    out.set_resolution(grid.resolution());
    absl::StatusOr<KeyBox> box = QueryKeyBox(grid, request.has_box(), request.box());
    if (!box.ok()) return box.status();
    const std::optional<KeyBox> bounds = labels.Bounds();
    if (!bounds || box->empty()) return absl::OkStatus();
    const std::optional<VoxelKey> next = WalkBoxPage(
        labels, *box, *bounds, *start, [&](const VoxelKey& k, const MultiLabelVoxel& v) {
          const MultiLabelVoxel::Entry best = v.Heaviest();
          if (best.count < min_count) return true;
          if (size_t(out.voxels_size()) == page) return false;
          v1::LabelVoxel* voxel = out.add_voxels();
          const Point3 c = grid.Center(k);
          voxel->mutable_center()->set_x(c.x);
          voxel->mutable_center()->set_y(c.y);
          voxel->mutable_center()->set_z(c.z);
          voxel->set_label(best.label);
          voxel->set_count(best.count);
          uint32_t total = 0;
          for (const MultiLabelVoxel::Entry& e : v.entries()) total += e.count;
          voxel->set_total(total);
          voxel->set_obj_id(ObjectOf(model, best.label));
          return true;
        });
    if (next) out.set_next_page_token(KeyPageToken(query, PackKey(*next)));
    return absl::OkStatus();
  });
  if (!status.ok()) return status;
  return out;
}

}  // namespace skimap::server
