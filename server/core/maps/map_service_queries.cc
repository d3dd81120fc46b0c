// MapService: spatial queries, each answered from one snapshot of the map.

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <optional>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "base/encoding.h"
#include "codec/zstd_frame.h"
#include "server/core/common/page_token.h"
#include "server/core/maps/free_space_grid.h"
#include "server/core/maps/grid_inflation.h"
#include "server/core/maps/grid_views.h"
#include "server/core/maps/map_service.h"
#include "server/core/maps/query_box.h"
#include "skimap/map_queries.h"

namespace skimap::server {
namespace {

constexpr int kDefaultVoxelPage = 10000;
constexpr int kMaxVoxelPage = 100000;
constexpr int kDefaultRadiusResults = 100000;
constexpr int kMaxRadiusResults = 1000000;

absl::StatusOr<std::optional<Region2D>> ToRegion(const v1::Region2D& r, bool present) {
  if (!present) return std::nullopt;
  if (!std::isfinite(r.min_x()) || !std::isfinite(r.min_y()) || !std::isfinite(r.max_x()) ||
      !std::isfinite(r.max_y()) || r.min_x() > r.max_x() || r.min_y() > r.max_y()) {
    return absl::InvalidArgumentError("region must be finite with min <= max");
  }
  return Region2D{r.min_x(), r.min_y(), r.max_x(), r.max_y()};
}

// The request's min_voxel_weight, or the map's when absent; the same rule as CreateMap's.
absl::StatusOr<float> MinWeight(bool present, float value, const MapConfig& config) {
  if (!present) return config.min_voxel_weight;
  if (!(value >= 0) || !std::isfinite(value)) {
    return absl::InvalidArgumentError(
        absl::StrCat("min_voxel_weight must be finite and >= 0, got ", value));
  }
  return value;
}

// Rasters whose reply would not fit in `max_reply_bytes` (the transport's message limit)
// are refused by the raster query itself, from the region and resolution, before anything
// is built: the largest raster of `bytes_per_cell` that fits.
constexpr size_t kReplyEnvelopeBytes = 1024;  // the reply's other fields
int64_t MaxReplyCells(size_t max_reply_bytes, size_t bytes_per_cell) {
  return int64_t(max_reply_bytes > kReplyEnvelopeBytes ? max_reply_bytes - kReplyEnvelopeBytes
                                                       : 0) /
         int64_t(bytes_per_cell);
}

absl::Status PrefixField(const absl::Status& s, absl::string_view field) {
  return absl::Status(s.code(), absl::StrCat(field, ": ", s.message()));
}

// The raster query's status; a refused size also names the reply limit it derives from
// (the core's message starts with "region: W x H cells exceeds the limit of N cells").
absl::Status RasterStatus(const absl::Status& s, absl::string_view what, size_t max_reply_bytes) {
  if (!absl::IsResourceExhausted(s)) return PrefixField(s, "region");
  return absl::ResourceExhaustedError(absl::StrCat(
      s.message(), " (the largest ", what, " that fits in the reply limit of ", max_reply_bytes,
      " bytes, max_reply_bytes, or 2^28 cells); ask for a smaller region"));
}

void FillVoxel(const Grid& grid, const VoxelKey& k, const RGBWeightedVoxel& v, v1::Voxel* out) {
  const Point3 c = grid.Center(k);
  out->mutable_center()->set_x(c.x);
  out->mutable_center()->set_y(c.y);
  out->mutable_center()->set_z(c.z);
  auto channel = [](float x) { return uint32_t(std::clamp(std::lround(x), 0l, 255l)); };
  out->set_rgb(channel(v.Red()) << 16 | channel(v.Green()) << 8 | channel(v.Blue()));
  out->set_weight(v.Weight());
}

template <class Raster>
void FillGeometry(const RasterGeometry& g, uint64_t frames, Raster* out) {
  out->set_resolution(g.resolution);
  out->set_width(g.width);
  out->set_height(g.height);
  out->set_origin_x(g.origin_x);
  out->set_origin_y(g.origin_y);
  out->set_frames(frames);
}

// What a GetVoxels page depends on but its position: the map (this incarnation of it), the
// box and the weight filter. The page size may change from page to page.
uint32_t VoxelQueryFingerprint(const LiveMap& map, const v1::GetVoxelsRequest& request) {
  std::string filters;
  Encoder e(&filters);
  EncodeQueryBox(request.has_box(), request.box(), e);
  e.U8(request.has_min_voxel_weight());
  e.F32(request.min_voxel_weight());
  if (request.level() != 0) e.U8(uint8_t(request.level()));  // tokens of level 0 unchanged
  return QueryFingerprint(map.incarnation(), "GetVoxels", filters);
}

constexpr int kMaxVoxelLevel = 8;

// GetVoxels with a level: the blocks of 2^level voxels a side holding voxels of `scan`
// (clipped to the map's bounds), in block key order, from block `start` (packed block key)
// on, at most `page` of them into `out`. Walks one x column of blocks at a time: a page
// merges no more than the slabs it needs. Returns the packed key of the next block if the
// page is full.
std::optional<uint64_t> AddVoxelBlocks(const Volume& volume, const KeyBox& scan, int level,
                                       std::optional<uint64_t> start, size_t page, float min_weight,
                                       v1::GetVoxelsResponse* out) {
  struct Block {
    double red = 0, green = 0, blue = 0, weight = 0;
  };
  const Grid& grid = volume.grid();
  const int32_t side = 1 << level;
  const double edge = grid.resolution() * side;
  const int32_t first = start ? UnpackKey(*start).x : scan.min.x >> level;
  for (int32_t bx = std::max(first, scan.min.x >> level); bx <= (scan.max.x >> level); ++bx) {
    KeyBox slab = scan;
    slab.min.x = std::max(scan.min.x, bx * side);
    slab.max.x = std::min(scan.max.x, bx * side + side - 1);
    std::map<uint64_t, Block> blocks;  // packed block key -> sums
    volume.ForEachInBox(slab, [&](const VoxelKey& k, const RGBWeightedVoxel& v) {
      if (v.Weight() < min_weight) return;
      Block& b = blocks[PackKey({k.x >> level, k.y >> level, k.z >> level})];
      const double w = std::max(v.Weight(), 1e-6f);
      b.red += v.Red() * w;
      b.green += v.Green() * w;
      b.blue += v.Blue() * w;
      b.weight += w;
    });
    for (const auto& [packed, b] : blocks) {
      if (start && packed < *start) continue;
      if (size_t(out->voxels_size()) == page) return packed;
      const VoxelKey key = UnpackKey(packed);
      v1::Voxel* voxel = out->add_voxels();
      voxel->mutable_center()->set_x(grid.origin().x + (key.x + 0.5) * edge);
      voxel->mutable_center()->set_y(grid.origin().y + (key.y + 0.5) * edge);
      voxel->mutable_center()->set_z(grid.origin().z + (key.z + 0.5) * edge);
      const double weight = b.weight;  // lambdas cannot capture bindings (clang 14)
      auto channel = [weight](double sum) {
        return uint32_t(std::clamp(std::lround(sum / weight), 0l, 255l));
      };
      voxel->set_rgb(channel(b.red) << 16 | channel(b.green) << 8 | channel(b.blue));
      voxel->set_weight(float(b.weight));
    }
  }
  return std::nullopt;
}

}  // namespace

absl::StatusOr<v1::OccupancyGrid> MapService::GetOccupancyGrid(
    const v1::GetOccupancyGridRequest& request) const {
  absl::StatusOr<std::shared_ptr<LiveMap>> map = FindMap(request.map(), "map");
  if (!map.ok()) return map.status();
  absl::StatusOr<std::optional<Region2D>> region = ToRegion(request.region(), request.has_region());
  if (!region.ok()) return region.status();
  const MapConfig& c = (*map)->config();
  OccupancyGridOptions o;
  o.region = *region;
  o.pool = pool_.get();  // shared with integration; ParallelFor calls take turns
  o.band_min_z = request.has_band_min_z() ? request.band_min_z() : c.band_min_z;
  o.band_max_z = request.has_band_max_z() ? request.band_max_z() : c.band_max_z;
  o.floor_min_z = request.has_floor_min_z() ? request.floor_min_z() : c.floor_min_z;
  absl::StatusOr<float> min_weight =
      MinWeight(request.has_min_voxel_weight(), request.min_voxel_weight(), c);
  if (!min_weight.ok()) return min_weight.status();
  o.min_weight = *min_weight;
  o.max_cells = MaxReplyCells(options_.max_reply_bytes, 1);  // one byte a cell
  if (!std::isfinite(o.band_min_z) || !std::isfinite(o.band_max_z) ||
      !std::isfinite(o.floor_min_z) || !(o.floor_min_z <= o.band_min_z) ||
      !(o.band_min_z <= o.band_max_z)) {
    return absl::InvalidArgumentError(
        "band_min_z: need finite floor_min_z <= band_min_z <= band_max_z");
  }
  const double inflation = request.inflation_radius();
  if (!(inflation >= 0 && inflation <= 5)) {
    return absl::InvalidArgumentError(
        absl::StrCat("inflation_radius: must be in [0, 5] metres, not ", inflation));
  }
  // One frame seeing through a column is evidence enough (not the surface threshold).
  constexpr uint32_t kMinFreeFrames = 1;
  if (!v1::GridEncoding_IsValid(request.data_encoding())) {
    return absl::InvalidArgumentError(
        absl::StrCat("data_encoding: unknown value ", request.data_encoding()));
  }
  v1::OccupancyGrid out;
  OccupancyGrid grid;
  absl::Status status = (*map)->Read([&](const MapState& state) {
    absl::StatusOr<OccupancyGrid> computed = state.grid_cache.Compute(state.rgb, o);
    if (!computed.ok()) {
      return RasterStatus(computed.status(), "occupancy grid", options_.max_reply_bytes);
    }
    grid = *std::move(computed);
    if (!request.keep_seen_through()) {
      ClearSeenThroughCells(state.rgb, skimap::internal::MakeOccupancyBands(state.rgb.grid(), o),
                            state.grid_views, &grid, o.pool);
    }
    MarkCarvedCells(state.free, kMinFreeFrames, &grid);
    FillGeometry(grid.geometry, state.frames, &out);
    return absl::OkStatus();
  });
  if (!status.ok()) return status;
  // Outside the map's lock, like the compression below.
  if (inflation > 0) InflateObstacles(inflation / grid.geometry.resolution, &grid);
  out.set_inflation_radius(inflation);
  out.set_data(reinterpret_cast<const char*>(grid.cells.data()), grid.cells.size());
  if (request.data_encoding() == v1::GRID_ENCODING_ZSTD) {  // outside the map's lock
    // One zstd frame at level 1: grids compress some 30-100x at a few hundred MB/s.
    absl::StatusOr<std::string> packed = perception::ZstdCompress(out.data());
    if (!packed.ok()) return packed.status();
    out.set_data(*std::move(packed));
    out.set_data_encoding(v1::GRID_ENCODING_ZSTD);
  }
  return out;
}

absl::StatusOr<v1::HeightMap> MapService::GetHeightMap(
    const v1::GetHeightMapRequest& request) const {
  absl::StatusOr<std::shared_ptr<LiveMap>> map = FindMap(request.map(), "map");
  if (!map.ok()) return map.status();
  absl::StatusOr<std::optional<Region2D>> region = ToRegion(request.region(), request.has_region());
  if (!region.ok()) return region.status();
  HeightMapOptions o;
  o.region = *region;
  o.pool = pool_.get();
  absl::StatusOr<float> min_weight =
      MinWeight(request.has_min_voxel_weight(), request.min_voxel_weight(), (*map)->config());
  if (!min_weight.ok()) return min_weight.status();
  o.min_weight = *min_weight;
  o.max_cells = MaxReplyCells(options_.max_reply_bytes, 4);  // packed float: 4 bytes a cell
  v1::HeightMap out;
  absl::Status status = (*map)->Read([&](const MapState& state) {
    absl::StatusOr<HeightMap> hm = ComputeHeightMap(state.rgb, o);
    if (!hm.ok()) return RasterStatus(hm.status(), "height map", options_.max_reply_bytes);
    FillGeometry(hm->geometry, state.frames, &out);
    out.mutable_heights()->Assign(hm->heights.begin(), hm->heights.end());
    return absl::OkStatus();
  });
  if (!status.ok()) return status;
  return out;
}

absl::StatusOr<v1::GetVoxelsResponse> MapService::GetVoxels(
    const v1::GetVoxelsRequest& request) const {
  absl::StatusOr<std::shared_ptr<LiveMap>> map = FindMap(request.map(), "map");
  if (!map.ok()) return map.status();
  if (request.page_size() < 0 || request.page_size() > kMaxVoxelPage) {
    return absl::InvalidArgumentError(absl::StrCat("page_size must be in 0..", kMaxVoxelPage));
  }
  const size_t page = request.page_size() == 0 ? kDefaultVoxelPage : request.page_size();
  if (request.level() < 0 || request.level() > kMaxVoxelLevel) {
    return absl::InvalidArgumentError(absl::StrCat("level must be in 0..", kMaxVoxelLevel));
  }
  absl::StatusOr<float> min_weight =
      MinWeight(request.has_min_voxel_weight(), request.min_voxel_weight(), (*map)->config());
  if (!min_weight.ok()) return min_weight.status();
  const uint32_t query = VoxelQueryFingerprint(**map, request);
  absl::StatusOr<std::optional<uint64_t>> start =
      DecodeKeyPageToken(request.page_token(), query, "GetVoxels");
  if (!start.ok()) return start.status();
  v1::GetVoxelsResponse out;
  absl::Status status = (*map)->Read([&](const MapState& state) -> absl::Status {
    const Volume& volume = state.rgb;
    const Grid& grid = volume.grid();
    out.set_resolution(grid.resolution());
    absl::StatusOr<KeyBox> box = QueryKeyBox(grid, request.has_box(), request.box());
    if (!box.ok()) return box.status();
    const std::optional<KeyBox> bounds = volume.Bounds();
    if (!bounds || box->empty()) return absl::OkStatus();
    if (request.level() > 0) {
      KeyBox scan = *box;
      scan.min = {std::max(scan.min.x, bounds->min.x), std::max(scan.min.y, bounds->min.y),
                  std::max(scan.min.z, bounds->min.z)};
      scan.max = {std::min(scan.max.x, bounds->max.x), std::min(scan.max.y, bounds->max.y),
                  std::min(scan.max.z, bounds->max.z)};
      out.set_resolution(grid.resolution() * (1 << request.level()));
      if (scan.empty()) return absl::OkStatus();
      const std::optional<uint64_t> next =
          AddVoxelBlocks(volume, scan, request.level(), *start, page, *min_weight, &out);
      if (next) out.set_next_page_token(KeyPageToken(query, *next));
      return absl::OkStatus();
    }
    const std::optional<VoxelKey> next = WalkBoxPage(
        volume, *box, *bounds, *start, [&](const VoxelKey& k, const RGBWeightedVoxel& v) {
          if (v.Weight() < *min_weight) return true;
          if (size_t(out.voxels_size()) == page) return false;
          FillVoxel(grid, k, v, out.add_voxels());
          return true;
        });
    if (next) out.set_next_page_token(KeyPageToken(query, PackKey(*next)));
    return absl::OkStatus();
  });
  if (!status.ok()) return status;
  return out;
}

absl::StatusOr<v1::Trajectory> MapService::GetTrajectory(
    const v1::GetTrajectoryRequest& request) const {
  constexpr int kDefaultPoses = 10000, kMaxPoses = 100000;
  if (request.max_poses() < 0 || request.max_poses() > kMaxPoses) {
    return absl::InvalidArgumentError(absl::StrCat("max_poses must be in 0..", kMaxPoses));
  }
  absl::StatusOr<std::shared_ptr<LiveMap>> map = FindMap(request.map(), "map");
  if (!map.ok()) return map.status();
  const size_t max = request.max_poses() == 0 ? kDefaultPoses : request.max_poses();
  const std::vector<std::pair<uint64_t, perception::CameraPose>> poses = (*map)->Trajectory();
  v1::Trajectory out;
  out.set_frames(poses.size());
  const size_t n = poses.size();
  const size_t kept = std::min(n, max);
  for (size_t k = 0; k < kept; ++k) {
    // Evenly spread indices, the first and the last included.
    const size_t i = kept == n ? k : (kept == 1 ? n - 1 : k * (n - 1) / (kept - 1));
    const auto& [sequence, pose] = poses[i];
    v1::TrajectoryPose* p = out.add_poses();
    p->set_sequence(sequence);
    v1::Quaternion* q = p->mutable_pose()->mutable_rotation();
    q->set_w(pose.rotation.w());
    q->set_x(pose.rotation.x());
    q->set_y(pose.rotation.y());
    q->set_z(pose.rotation.z());
    v1::Vec3* t = p->mutable_pose()->mutable_translation();
    t->set_x(pose.translation.x());
    t->set_y(pose.translation.y());
    t->set_z(pose.translation.z());
  }
  return out;
}

absl::StatusOr<v1::RadiusSearchResponse> MapService::RadiusSearch(
    const v1::RadiusSearchRequest& request) const {
  absl::StatusOr<std::shared_ptr<LiveMap>> map = FindMap(request.map(), "map");
  if (!map.ok()) return map.status();
  const v1::Vec3& c = request.center();
  if (!std::isfinite(c.x()) || !std::isfinite(c.y()) || !std::isfinite(c.z())) {
    return absl::InvalidArgumentError("center must be finite");
  }
  if (!(request.radius() > 0 && request.radius() <= 100)) {
    return absl::InvalidArgumentError("radius must be in (0, 100] metres");
  }
  if (request.max_results() < 0 || request.max_results() > kMaxRadiusResults) {
    return absl::InvalidArgumentError(
        absl::StrCat("max_results must be in 0..", kMaxRadiusResults));
  }
  const int limit = request.max_results() == 0 ? kDefaultRadiusResults : request.max_results();
  absl::StatusOr<float> min_weight =
      MinWeight(request.has_min_voxel_weight(), request.min_voxel_weight(), (*map)->config());
  if (!min_weight.ok()) return min_weight.status();
  v1::RadiusSearchResponse out;
  (*map)->Read([&](const MapState& state) {
    const Volume& volume = state.rgb;
    volume.RadiusSearch({c.x(), c.y(), c.z()}, request.radius(),
                        [&](const VoxelKey& k, const RGBWeightedVoxel& v) {
                          if (v.Weight() < *min_weight) return;
                          if (out.voxels_size() == limit) {
                            out.set_truncated(true);
                            return;
                          }
                          FillVoxel(volume.grid(), k, v, out.add_voxels());
                        });
    return 0;
  });
  return out;
}

}  // namespace skimap::server
