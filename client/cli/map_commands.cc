#include "client/cli/map_commands.h"

#include <cstdio>

#include "client/cli/map_option_flags.h"
#include "client/cli/transfer_command.h"
#include "client/map_files.h"

namespace skimap::client {
namespace {

int Fail(const absl::Status& s) {
  std::fprintf(stderr, "skimap: %s\n", s.ToString().c_str());
  return 1;
}

void PrintMap(const v1::Map& m) {
  const v1::MapStats& s = m.stats();
  std::printf("%s  resolution %.3g m  voxels %llu  frames %llu  memory %.1f MiB", m.name().c_str(),
              m.options().resolution(), (unsigned long long)s.voxels(),
              (unsigned long long)s.frames(), s.memory_bytes() / 1048576.0);
  if (s.has_bounds()) {
    std::printf("  bounds [%.2f %.2f %.2f] .. [%.2f %.2f %.2f]", s.bounds().min().x(),
                s.bounds().min().y(), s.bounds().min().z(), s.bounds().max().x(),
                s.bounds().max().y(), s.bounds().max().z());
  }
  if (!m.owner_node().empty()) {
    std::printf("  owner %s (%s)", m.owner_node().c_str(), m.owner_address().c_str());
  }
  std::printf("\n");
}

// `skimap nodes`: one line per node of the fleet, then its maps.
int Nodes(MapClient& client) {
  absl::StatusOr<v1::ListNodesResponse> nodes = client.ListNodes();
  if (!nodes.ok()) return Fail(nodes.status());
  for (const v1::Node& n : nodes->nodes()) {
    std::printf("%s  %s  %s%s  %d maps\n", n.id().c_str(), n.address().c_str(),
                n.live() ? "live" : "silent", n.answering() ? " (answered)" : "", n.maps_size());
    for (const std::string& m : n.maps()) std::printf("  %s\n", m.c_str());
  }
  if (nodes->nodes_size() == 0) std::printf("(no nodes)\n");
  return 0;
}

// `skimap health`: SERVING and exit 0, or the reason and exit 1 (container health checks:
// the standard gRPC health service answers without a token).
int Health(MapClient& client) {
  if (absl::Status s = client.CheckHealth(); !s.ok()) return Fail(s);
  std::printf("SERVING\n");
  return 0;
}

int Maps(MapClient& client, const std::vector<std::string>& args, const MapCommandFlags& flags) {
  const std::string verb = args.size() > 2 ? args[2] : "ls";
  if (verb == "ls") {
    absl::StatusOr<std::vector<v1::Map>> maps = client.ListAllMaps();
    if (!maps.ok()) return Fail(maps.status());
    for (const v1::Map& m : *maps) PrintMap(m);
    if (maps->empty()) std::printf("(no maps)\n");
    return 0;
  }
  if (args.size() < 4) return Fail(absl::InvalidArgumentError("maps " + verb + " needs an ID"));
  const std::string id = args[3];
  if (verb == "create") {
    v1::CreateMapRequest request;
    request.set_map_id(id);
    if (absl::Status s = ApplyMapOptionFlags(request.mutable_options()); !s.ok()) {
      return Fail(s);
    }
    request.mutable_options()->set_resolution(flags.resolution);
    absl::StatusOr<v1::Map> map = client.CreateMap(request);
    if (!map.ok()) return Fail(map.status());
    PrintMap(*map);
    return 0;
  }
  if (verb == "rm") {
    if (absl::Status s = client.DeleteMap("maps/" + id); !s.ok()) return Fail(s);
    std::printf("deleted maps/%s\n", id.c_str());
    return 0;
  }
  if (verb == "info") {
    absl::StatusOr<v1::Map> map = client.GetMap("maps/" + id);
    if (!map.ok()) return Fail(map.status());
    std::printf("%s\n", map->DebugString().c_str());
    return 0;
  }
  return Fail(absl::InvalidArgumentError("maps: ls | create ID | rm ID | info ID"));
}

int Grid(MapClient& client, const MapCommandFlags& flags) {
  v1::GetOccupancyGridRequest request;
  request.set_map("maps/" + flags.map);
  request.set_data_encoding(v1::GRID_ENCODING_ZSTD);  // fewer bytes on the wire
  if (const double r = flags.inflation_radius; r != 0) {
    request.set_inflation_radius(r);
  }
  request.set_keep_seen_through(flags.keep_seen_through);
  absl::StatusOr<v1::OccupancyGrid> grid = client.GetOccupancyGrid(request);
  if (!grid.ok()) return Fail(grid.status());
  const std::string& out = flags.out;
  if (absl::Status s = WriteRosMap(*grid, out); !s.ok()) return Fail(s);
  std::printf("occupancy grid %ux%u cells at %.3g m -> %s (+ %s)\n", grid->width(), grid->height(),
              grid->resolution(), out.c_str(), ReplaceExtension(out, ".pgm").c_str());
  return 0;
}

int HeightMap(MapClient& client, const MapCommandFlags& flags) {
  v1::GetHeightMapRequest request;
  request.set_map("maps/" + flags.map);
  absl::StatusOr<v1::HeightMap> map = client.GetHeightMap(request);
  if (!map.ok()) return Fail(map.status());
  const std::string& out = flags.out;
  if (absl::Status s = WriteHeightMap(*map, out); !s.ok()) return Fail(s);
  std::printf("height map %ux%u cells at %.3g m -> %s (+ %s)\n", map->width(), map->height(),
              map->resolution(), out.c_str(), ReplaceExtension(out, ".yaml").c_str());
  return 0;
}

int Voxels(MapClient& client, const MapCommandFlags& flags) {
  v1::GetVoxelsRequest request;
  request.set_map("maps/" + flags.map);
  request.set_page_size(50000);
  absl::StatusOr<std::vector<v1::Voxel>> voxels = client.GetAllVoxels(request);
  if (!voxels.ok()) return Fail(voxels.status());
  const std::string& out = flags.out;
  if (absl::Status s = WritePly(*voxels, out); !s.ok()) return Fail(s);
  std::printf("%zu voxels -> %s\n", voxels->size(), out.c_str());
  return 0;
}

int Export(MapClient& client, const MapCommandFlags& flags) {
  const std::string& id = flags.map;
  const std::string& out = flags.out;
  const bool journal = flags.with_journal;
  absl::StatusOr<uint64_t> bytes = ExportMapToFile(client, id, out, journal);
  if (!bytes.ok()) return Fail(bytes.status());
  std::printf("maps/%s -> %s (%llu bytes%s)\n", id.c_str(), out.c_str(), (unsigned long long)*bytes,
              journal ? ", with journal" : "");
  return 0;
}

int Import(MapClient& client, const std::vector<std::string>& args, const MapCommandFlags& flags) {
  if (args.size() < 3) return Fail(absl::InvalidArgumentError("import needs a FILE"));
  absl::StatusOr<v1::Map> map = ImportMapFromFile(client, args[2], flags.as);
  if (!map.ok()) return Fail(map.status());
  std::printf("%s <- ", args[2].c_str());
  PrintMap(*map);
  return 0;
}

}  // namespace

int RunMapCommand(MapClient& client, const std::vector<std::string>& args,
                  const MapCommandFlags& flags) {
  const std::string& command = args[1];
  if (command == "maps") return Maps(client, args, flags);
  if (command == "nodes") return Nodes(client);
  if (command == "health") return Health(client);
  if (command == "import") return Import(client, args, flags);
  if (command == "grid") return Grid(client, flags);
  if (command == "heightmap") return HeightMap(client, flags);
  if (command == "voxels") return Voxels(client, flags);
  if (command == "export") return Export(client, flags);
  return Fail(absl::InvalidArgumentError("unknown command " + command + " (see --help)"));
}

}  // namespace skimap::client
