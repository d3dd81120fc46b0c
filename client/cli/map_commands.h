// The `skimap` commands on maps and the fleet (client/cli/skimap_main.cc lists their
// usage): maps ls | create ID | rm ID | info ID, nodes, health, grid (ROS map_server PGM +
// YAML), heightmap (PNG or TIFF + YAML), voxels (PLY), export and import
// (transfer_command.h). Each prints what it did on stdout and an error on stderr.
//
//   return RunMapCommand(*client, args, {.map = "kitchen", .out = "grid.yaml"});
//
// Thread safety: one command at a time (the client itself is shared).
#ifndef CLIENT_CLI_MAP_COMMANDS_H_
#define CLIENT_CLI_MAP_COMMANDS_H_

#include <string>
#include <vector>

#include "client/map_client.h"

namespace skimap::client {

// The flags these commands read (skimap_main.cc defines and checks them).
struct MapCommandFlags {
  std::string map;                 // --map: the map id of grid, heightmap, voxels, export
  std::string out;                 // -o: the output file
  double resolution = 0.05;        // --resolution for maps create
  double inflation_radius = 0;     // grid: --inflation_radius (0: trinary)
  bool keep_seen_through = false;  // grid: --keep_seen_through
  bool with_journal = false;       // export: --with-journal
  std::string as;                  // import: --as (""  keeps the file's id)
};

// Runs command args[1] (args[0] is the program); returns the exit status: 0, or 1 after
// printing the error (an unknown command included).
int RunMapCommand(MapClient& client, const std::vector<std::string>& args,
                  const MapCommandFlags& flags);

}  // namespace skimap::client

#endif  // CLIENT_CLI_MAP_COMMANDS_H_
