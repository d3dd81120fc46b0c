// Integration tests over real gRPC (localhost socket): maps, frames, queries.
#include <zstd.h>

#include <cmath>

#include "server/core/maps/map_config.h"
#include "tests/common/synthetic_scene.h"
#include "tests/server/maps/server_fixture.h"

namespace skimap::testing {
namespace {

using ::testing::HasSubstr;

TEST_F(ServerTest, CreateGetListDeleteMaps) {
  CreateMap("alpha");
  CreateMap("beta", 0.02);
  v1::CreateMapRequest dup;
  dup.set_map_id("alpha");
  EXPECT_EQ(client_->CreateMap(dup).status().code(), absl::StatusCode::kAlreadyExists);
  dup.set_map_id("Bad Name");
  auto bad = client_->CreateMap(dup);
  EXPECT_EQ(bad.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(bad.status().message(), HasSubstr("map_id"));
  dup.set_map_id("gamma");
  dup.mutable_options()->set_resolution(-1);
  EXPECT_THAT(client_->CreateMap(dup).status().message(), HasSubstr("options.resolution"));

  auto beta = client_->GetMap("maps/beta");
  ASSERT_TRUE(beta.ok()) << beta.status();
  EXPECT_DOUBLE_EQ(beta->options().resolution(), 0.02);
  EXPECT_DOUBLE_EQ(beta->options().max_depth(), 5.0);  // default filled in
  EXPECT_EQ(beta->stats().voxels(), 0u);
  EXPECT_FALSE(beta->stats().has_bounds());

  v1::ListMapsRequest page;
  page.set_page_size(1);
  auto first = client_->ListMaps(page);
  ASSERT_TRUE(first.ok());
  ASSERT_EQ(first->maps_size(), 1);
  EXPECT_EQ(first->maps(0).name(), "maps/alpha");
  page.set_page_token(first->next_page_token());
  auto second = client_->ListMaps(page);
  ASSERT_TRUE(second.ok());
  ASSERT_EQ(second->maps_size(), 1);
  EXPECT_EQ(second->maps(0).name(), "maps/beta");
  EXPECT_TRUE(second->next_page_token().empty());

  EXPECT_TRUE(client_->DeleteMap("maps/alpha").ok());
  EXPECT_EQ(client_->GetMap("maps/alpha").status().code(), absl::StatusCode::kNotFound);
  EXPECT_EQ(client_->DeleteMap("maps/alpha").code(), absl::StatusCode::kNotFound);
  EXPECT_EQ(client_->GetMap("alpha").status().code(), absl::StatusCode::kInvalidArgument);
}

TEST_F(ServerTest, OccupancyGridMarksTheBoxAndTheVisibleFloor) {
  CreateMap("room");
  auto ack = client_->IntegrateFrame(MakeFrame("maps/room", 1, DefaultView()));
  ASSERT_TRUE(ack.ok()) << ack.status();
  // Measured 5 862 voxels (2026-11-23); the floor is two thirds of it.
  EXPECT_GT(ack->voxels_touched(), 3900u);
  // Every pixel has depth; those at the box's silhouette (a depth step) are flying-pixel
  // candidates and dropped (MapOptions.depth_edge_jump, default 0.05).
  EXPECT_EQ(ack->points() + ack->points_at_depth_edges(), 160u * 120u);
  EXPECT_GT(ack->points_at_depth_edges(), 0u);
  EXPECT_LT(ack->points_at_depth_edges(), 160u * 120u / 20);

  v1::GetOccupancyGridRequest request;
  request.set_map("maps/room");
  request.mutable_region()->set_min_x(-1.0);
  request.mutable_region()->set_min_y(-1.0);
  request.mutable_region()->set_max_x(2.0);
  request.mutable_region()->set_max_y(1.0);
  auto grid = client_->GetOccupancyGrid(request);
  ASSERT_TRUE(grid.ok()) << grid.status();
  ASSERT_EQ(grid->data().size(), size_t(grid->width()) * grid->height());
  EXPECT_EQ(grid->frames(), 1u);
  const SceneBox box;
  const double res = grid->resolution();
  int occupied_inside = 0, inside = 0;
  for (uint32_t j = 0; j < grid->height(); ++j) {
    for (uint32_t i = 0; i < grid->width(); ++i) {
      const double x = grid->origin_x() + (i + 0.5) * res, y = grid->origin_y() + (j + 0.5) * res;
      const int8_t cell = static_cast<int8_t>(grid->data()[j * grid->width() + i]);
      const bool in_box = x > box.min.x() + res && x < box.max.x() - res && y > box.min.y() + res &&
                          y < box.max.y() - res;
      const bool near_box = x > box.min.x() - res && x < box.max.x() + res &&
                            y > box.min.y() - res && y < box.max.y() + res;
      if (in_box) {
        ++inside;
        occupied_inside += cell == 100;
      }
      if (!near_box) {
        EXPECT_NE(cell, 100) << "occupied cell off the box at " << x << ", " << y;
      }
    }
  }
  EXPECT_EQ(occupied_inside, inside);
  auto cell_at = [&](double x, double y) {
    const int i = int(std::floor((x - grid->origin_x()) / res));
    const int j = int(std::floor((y - grid->origin_y()) / res));
    return static_cast<int8_t>(grid->data()[j * grid->width() + i]);
  };
  EXPECT_EQ(cell_at(0.0, 0.6), 0) << "visible floor is free";
  // The floor in the box's shadow is hidden, but rays over the box crossed the band above
  // it: free-space carving (on by default) makes the column free.
  EXPECT_EQ(cell_at(1.2, 0.0), 0) << "the band over the box's shadow was seen through";
  EXPECT_EQ(cell_at(0.5, 0.0), 100) << "occupied wins";
}

TEST_F(ServerTest, AZstdGridIsTheRawGridCompressed) {
  CreateMap("packed");
  ASSERT_TRUE(client_->IntegrateFrame(MakeFrame("maps/packed", 1, DefaultView())).ok());
  v1::GetOccupancyGridRequest request;
  request.set_map("maps/packed");
  request.mutable_region()->set_min_x(-3.0);
  request.mutable_region()->set_min_y(-3.0);
  request.mutable_region()->set_max_x(3.0);
  request.mutable_region()->set_max_y(3.0);
  auto raw = client_->GetOccupancyGrid(request);
  ASSERT_TRUE(raw.ok()) << raw.status();
  EXPECT_EQ(raw->data_encoding(), v1::GRID_ENCODING_RAW);
  const size_t cells = size_t(raw->width()) * raw->height();
  ASSERT_EQ(raw->data().size(), cells);

  // On the wire (the stub, not the client library): one zstd frame of the same cells.
  request.set_data_encoding(v1::GRID_ENCODING_ZSTD);
  grpc::ClientContext ctx;
  v1::OccupancyGrid wire;
  ASSERT_TRUE(client_->stub().GetOccupancyGrid(&ctx, request, &wire).ok());
  EXPECT_EQ(wire.data_encoding(), v1::GRID_ENCODING_ZSTD);
  EXPECT_EQ(wire.width(), raw->width());
  EXPECT_LT(wire.data().size(), cells / 10) << "a mostly unknown grid compresses well";
  std::string unpacked(cells, '\0');
  ASSERT_EQ(ZSTD_decompress(unpacked.data(), cells, wire.data().data(), wire.data().size()), cells);
  EXPECT_EQ(unpacked, raw->data());

  // The client library hands back raw data.
  auto through_library = client_->GetOccupancyGrid(request);
  ASSERT_TRUE(through_library.ok()) << through_library.status();
  EXPECT_EQ(through_library->data_encoding(), v1::GRID_ENCODING_RAW);
  EXPECT_EQ(through_library->data(), raw->data());

  request.set_data_encoding(static_cast<v1::GridEncoding>(7));
  auto bad = client_->GetOccupancyGrid(request);
  EXPECT_EQ(bad.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(bad.status().message(), HasSubstr("data_encoding"));
}

TEST_F(ServerTest, HeightMapMatchesBoxTopAndFloor) {
  CreateMap("heights");
  ASSERT_TRUE(client_->IntegrateFrame(MakeFrame("maps/heights", 1, DefaultView())).ok());
  v1::GetHeightMapRequest request;
  request.set_map("maps/heights");
  auto map = client_->GetHeightMap(request);
  ASSERT_TRUE(map.ok()) << map.status();
  ASSERT_EQ(map->heights_size(), int(map->width() * map->height()));
  auto height_at = [&](double x, double y) {
    const int i = int(std::floor((x - map->origin_x()) / map->resolution()));
    const int j = int(std::floor((y - map->origin_y()) / map->resolution()));
    return map->heights(j * map->width() + i);
  };
  EXPECT_NEAR(height_at(0.5, 0.0), 0.5, 0.05);   // box top, within one voxel
  EXPECT_NEAR(height_at(0.0, 0.6), 0.0, 0.05);   // floor
  EXPECT_TRUE(std::isnan(height_at(1.2, 0.0)));  // shadow: unknown
}

TEST_F(ServerTest, UpdatePosesMovesContentWithoutResidue) {
  CreateMap("moved");
  CreateMap("reference");
  Eigen::Isometry3d shifted = DefaultView();
  shifted.translation().y() += 1.0;
  // The frame rendered from the default view, but believed to be taken 1 m to the left.
  v1::Frame frame = MakeFrame("maps/moved", 7, DefaultView());
  ASSERT_TRUE(client_->IntegrateFrame(frame).ok());
  v1::UpdatePosesRequest update;
  update.set_map("maps/moved");
  update.add_updates()->set_sequence(7);
  SetPose(shifted, update.mutable_updates(0)->mutable_pose());
  auto updated = client_->UpdatePoses(update);
  ASSERT_TRUE(updated.ok()) << updated.status();
  EXPECT_EQ(updated->frames_updated(), 1u);

  frame.set_map("maps/reference");
  SetPose(shifted, frame.mutable_pose());
  ASSERT_TRUE(client_->IntegrateFrame(frame).ok());

  v1::GetVoxelsRequest all;
  all.set_map("maps/moved");
  auto moved = client_->GetAllVoxels(all);
  all.set_map("maps/reference");
  auto reference = client_->GetAllVoxels(all);
  ASSERT_TRUE(moved.ok() && reference.ok());
  ASSERT_EQ(moved->size(), reference->size());
  for (size_t i = 0; i < moved->size(); ++i) {
    ASSERT_DOUBLE_EQ((*moved)[i].center().y(), (*reference)[i].center().y());
    ASSERT_DOUBLE_EQ((*moved)[i].center().x(), (*reference)[i].center().x());
    ASSERT_FLOAT_EQ((*moved)[i].weight(), (*reference)[i].weight());
  }
  // Nothing is left where the box stood before the move.
  v1::RadiusSearchRequest search;
  search.set_map("maps/moved");
  search.mutable_center()->set_x(0.5);
  search.mutable_center()->set_z(0.3);
  search.set_radius(0.25);  // reaches the box faces, not the floor
  auto residue = client_->RadiusSearch(search);
  ASSERT_TRUE(residue.ok());
  EXPECT_EQ(residue->voxels_size(), 0);
  search.mutable_center()->set_y(1.0);
  auto box = client_->RadiusSearch(search);
  ASSERT_TRUE(box.ok());
  EXPECT_GT(box->voxels_size(), 0);

  update.mutable_updates(0)->set_sequence(99);
  EXPECT_EQ(client_->UpdatePoses(update).status().code(), absl::StatusCode::kNotFound);
  update.mutable_updates(0)->set_sequence(7);
  update.mutable_updates(0)->mutable_pose()->mutable_rotation()->set_w(3);
  auto bad = client_->UpdatePoses(update);
  EXPECT_EQ(bad.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(bad.status().message(), HasSubstr("updates[0].pose.rotation"));
}

TEST_F(ServerTest, VoxelPagesCoverTheMapOnceInKeyOrder) {
  CreateMap("paged");
  ASSERT_TRUE(client_->IntegrateFrame(MakeFrame("maps/paged", 1, DefaultView())).ok());
  auto info = client_->GetMap("maps/paged");
  ASSERT_TRUE(info.ok());
  v1::GetVoxelsRequest request;
  request.set_map("maps/paged");
  request.set_page_size(97);
  size_t total = 0, pages = 0;
  do {
    auto page = client_->GetVoxels(request);
    ASSERT_TRUE(page.ok()) << page.status();
    total += page->voxels_size();
    ++pages;
    request.set_page_token(page->next_page_token());
  } while (!request.page_token().empty());
  EXPECT_EQ(total, info->stats().voxels());
  EXPECT_EQ(pages, (total + 96) / 97);  // full pages of 97 but the last (61 measured)
  request.set_page_token("garbage");
  EXPECT_EQ(client_->GetVoxels(request).status().code(), absl::StatusCode::kInvalidArgument);
  request.clear_page_token();
  auto streamed = client_->GetAllVoxels(request);
  ASSERT_TRUE(streamed.ok());
  EXPECT_EQ(streamed->size(), total);
}

TEST_F(ServerTest, SecondServerCannotTakeAPortInUse) {
  // gRPC would share the port (SO_REUSEPORT) and split the clients between two servers.
  server::Server::Options options;
  options.grpc.address = absl::StrCat("127.0.0.1:", server_->grpc_port());
  auto second = server::Server::Start(options);
  ASSERT_FALSE(second.ok());
  EXPECT_EQ(second.status().code(), absl::StatusCode::kUnavailable);
  EXPECT_THAT(second.status().message(), ::testing::HasSubstr(options.grpc.address));
  // The first server still answers.
  EXPECT_TRUE(client_->ListMaps(v1::ListMapsRequest()).ok());
}

}  // namespace
}  // namespace skimap::testing

namespace skimap::testing {
namespace {

// New maps get today's defaults; options a store or an export file holds from before
// depth_edge_jump existed read 0, the way their frames were integrated (journal replay and
// UpdatePoses rebuild frames with the map's options and must match what was acknowledged).
TEST(MapConfigTest, DefaultsForNewMapsAndOptionsStoredBeforeAFieldExisted) {
  absl::StatusOr<server::MapConfig> fresh = server::ResolveMapOptions(v1::MapOptions());
  ASSERT_TRUE(fresh.ok()) << fresh.status();
  EXPECT_TRUE(fresh->carve_free_space);
  EXPECT_DOUBLE_EQ(fresh->integration.depth_edge_jump, 0.05);
  v1::MapOptions old = server::ToProto(*fresh);
  old.clear_depth_edge_jump();  // as written before the field existed
  old.set_carve_free_space(false);
  absl::StatusOr<server::MapConfig> stored = server::ResolveStoredMapOptions(old);
  ASSERT_TRUE(stored.ok()) << stored.status();
  EXPECT_DOUBLE_EQ(stored->integration.depth_edge_jump, 0);
  EXPECT_FALSE(stored->carve_free_space);
  // A stored value is kept; a bad one is refused naming the field.
  old.set_depth_edge_jump(0.1);
  EXPECT_DOUBLE_EQ(server::ResolveStoredMapOptions(old)->integration.depth_edge_jump, 0.1);
  v1::MapOptions bad;
  bad.set_depth_edge_jump(-0.1);
  EXPECT_NE(server::ResolveMapOptions(bad).status().message().find("options.depth_edge_jump"),
            std::string::npos);
}

}  // namespace
}  // namespace skimap::testing

namespace skimap::testing {
namespace {

// GetOccupancyGridRequest.inflation_radius: the box's footprint stays occupied, free cells
// beside it get costs falling with the distance, far cells stay free, unknown stays
// unknown; a radius outside [0, 5] m is refused by name.
TEST_F(ServerTest, InflationMakesACostGridAroundObstacles) {
  CreateMap("costs");
  ASSERT_TRUE(client_->IntegrateFrame(MakeFrame("maps/costs", 1, DefaultView())).ok());
  v1::GetOccupancyGridRequest request;
  request.set_map("maps/costs");
  auto* region = request.mutable_region();
  region->set_min_x(-1.0), region->set_min_y(-1.0), region->set_max_x(2.0), region->set_max_y(1.0);
  auto trinary = client_->GetOccupancyGrid(request);
  request.set_inflation_radius(0.3);
  auto costs = client_->GetOccupancyGrid(request);
  ASSERT_TRUE(trinary.ok() && costs.ok()) << trinary.status() << costs.status();
  EXPECT_DOUBLE_EQ(costs->inflation_radius(), 0.3);
  EXPECT_DOUBLE_EQ(trinary->inflation_radius(), 0);
  ASSERT_EQ(trinary->data().size(), costs->data().size());
  const double res = costs->resolution();
  auto at = [&](const v1::OccupancyGrid& g, double x, double y) {
    const int i = int(std::floor((x - g.origin_x()) / res));
    const int j = int(std::floor((y - g.origin_y()) / res));
    return static_cast<int8_t>(g.data()[j * g.width() + i]);
  };
  int costed = 0;
  for (size_t i = 0; i < costs->data().size(); ++i) {
    const int8_t before = trinary->data()[i], after = costs->data()[i];
    if (before != 0) {
      EXPECT_EQ(after, before) << "only free cells get costs";
    } else {
      EXPECT_GE(after, 0);
      EXPECT_LE(after, 99);
      costed += after > 0;
    }
  }
  EXPECT_GT(costed, 20);
  // The box spans x 0.3-0.7 at y in [-0.2, 0.2]; the camera sees its front at x = 0.3.
  EXPECT_EQ(at(*costs, 0.5, 0.0), 100);
  const int8_t near = at(*costs, 0.22, 0.0), mid = at(*costs, 0.12, 0.0),
               far = at(*costs, -0.3, 0.0);
  EXPECT_GT(near, mid) << "costs fall with the distance";
  EXPECT_GT(mid, 0);
  EXPECT_EQ(far, 0) << "beyond the radius";
  request.set_inflation_radius(7);
  auto bad = client_->GetOccupancyGrid(request);
  EXPECT_EQ(bad.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(bad.status().message().find("inflation_radius"), std::string::npos);
}

}  // namespace
}  // namespace skimap::testing
