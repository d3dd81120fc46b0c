// skimap: command-line client of skimapd.
//
//   skimap [--server=localhost:50051] maps ls | maps create ID [--resolution=0.05]
//                                     | maps rm ID | maps info ID
//   skimap stream DATASET|BAG --map=ID [--fps=0] [--resolution=0.05] [--depth_encoding=auto]
//                                              (creates ID if missing; BAG: a ROS 1 .bag,
//                                              a ROS 2 .mcap or .db3 or rosbag2 folder, with
//                                              --depth_topic, --color_topic,
//                                              --camera_info_topic, --fixed_frame,
//                                              --camera_frame, --sync_tolerance: docs/ros.md)
//   maps create, stream and eval also take the MapOptions fields as flags
//   (--band_min_z, --carve_free_space, ...: client/cli/map_option_flags.h)
//   skimap grid --map=ID -o FILE.yaml [--inflation_radius=M] [--keep_seen_through]
//                                              ROS map_server PGM + YAML (trinary; raw
//                                              costs with inflation)
//   skimap heightmap --map=ID -o FILE.png|FILE.tiff   (+ FILE.yaml sidecar)
//   skimap voxels --map=ID -o FILE.ply
//   skimap export --map=ID -o FILE [--with-journal]   the map as one export file
//   skimap import FILE [--as=ID]                       a map from an export file
//     (client/cli/transfer_command.h)
//   skimap objects ls | info ID | rm ID | train DATASET [--object=ID] | add MODEL --object=ID
//                  | build | classifier
//     (client/cli/objects_command.h)
//   skimap nodes                               a fleet's nodes and the maps each serves
//   skimap instances --map=ID [--box=..|--sphere=..] [--objects=..] [--min_score=S] [--json]
//     (client/cli/instances_command.h); `stream --recognition=newest` creates a map with it on
//   skimap eval DATASET [--scenes=..] [--every=N] [--max_frames=N] [--csv=FILE] [--train]
//     recognition precision / recall on a BOP dataset's test scenes (client/cli/eval_command.h)
//
// Authentication and TLS (docs/operations.md): --token_file=FILE (or $SKIMAP_TOKEN) sends
// `authorization: Bearer <token>`; --tls_ca=PEM [--tls_cert=PEM --tls_key=PEM] connect
// over TLS (with a client certificate: mTLS).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "absl/flags/flag.h"
#include "absl/flags/parse.h"
#include "absl/flags/usage.h"
#include "absl/strings/str_format.h"
#include "client/cli/eval_command.h"
#ifdef SKIMAP_WITH_ROS
#include "client/cli/bag_frame_source.h"
#endif
#include "client/cli/instances_command.h"
#include "client/cli/map_commands.h"
#include "client/cli/map_option_flags.h"
#include "client/cli/objects_command.h"
#include "client/cli/stream_command.h"
#include "client/cli/transfer_command.h"
#include "client/map_client.h"

ABSL_FLAG(std::string, server, "localhost:50051", "skimapd address host:port");
ABSL_FLAG(std::string, map, "", "map id (maps/ID)");
ABSL_FLAG(std::string, o, "", "output file");
ABSL_FLAG(double, fps, 0, "stream: frames per second (0 = as fast as the server takes them)");
ABSL_FLAG(double, resolution, 0,
          "maps create / stream / eval: voxel size in metres (0 = the command's default: "
          "maps create and stream 0.05, eval 0.02)");
ABSL_FLAG(int, window, 8, "stream: unacknowledged frames in flight");
ABSL_FLAG(double, inflation_radius, 0,
          "grid: inflate obstacles by this many metres into a cost grid (PGM in map_server's "
          "raw mode: 0 free, 1-99 cost, 100 occupied, 255 unknown); 0 = trinary");
ABSL_FLAG(bool, keep_seen_through, false,
          "grid: keep obstacles that a later camera view saw through (by default they are "
          "cleared: docs/api.md, \"Seen-through obstacles\")");
ABSL_FLAG(std::string, depth_encoding, "auto",
          "stream: depth on the wire, lossless: auto (the default: a dataset's 16-bit PNG files "
          "as stored, anything else, bags too, as zstd), zstd, rvl, png16 (the dataset's files "
          "as stored) or raw");
ABSL_FLAG(bool, with_journal, false,
          "export: also the map's journal (UpdatePoses then works on the imported frames)");
ABSL_FLAG(std::string, as, "", "import: the new map's id (default: the id in the file)");
ABSL_FLAG(std::string, recognition, "off",
          "stream: when the map is created, recognition on it: off, newest (skip frames while "
          "busy) or every_frame (acks wait for it)");
ABSL_FLAG(std::string, box, "", "instances: region X0,Y0,Z0,X1,Y1,Z1 in metres");
ABSL_FLAG(std::string, sphere, "", "instances: region X,Y,Z,R in metres");
ABSL_FLAG(std::string, objects, "", "instances: only these obj_ids, e.g. 1,5");
ABSL_FLAG(double, min_score, 0, "instances: minimum score");
ABSL_FLAG(bool, json, false, "instances: JSON in the BOP convention (R row-major, t in mm)");
ABSL_FLAG(std::string, scenes, "", "eval: test scene folder names, comma-separated (default all)");
ABSL_FLAG(int, every, 1, "stream / eval: send every n-th frame");
ABSL_FLAG(int, max_frames, 0, "stream: frames at most; eval: frames per scene at most (0 = all)");
ABSL_FLAG(std::string, depth_topic, "",
          "stream BAG: the depth image topic (default: chosen from the bag; docs/ros.md)");
ABSL_FLAG(std::string, color_topic, "",
          "stream BAG: the colour image topic, raw or compressed (- for none)");
ABSL_FLAG(std::string, camera_info_topic, "", "stream BAG: the depth camera's camera_info");
ABSL_FLAG(std::string, fixed_frame, "",
          "stream BAG: tf frame the poses are in (default: the root of the camera's tree)");
ABSL_FLAG(std::string, camera_frame, "",
          "stream BAG: the camera's tf frame (default: the depth image's frame_id)");
ABSL_FLAG(double, sync_tolerance, 0.02,
          "stream BAG: seconds between a depth image and the colour image it pairs with");
ABSL_FLAG(double, bag_check_seconds, 0,
          "stream BAG: a ROS 1 bag is first read by a child process, refused when it takes "
          "longer than this (0 = 60 s plus 1 s per 20 MB of bag)");
ABSL_FLAG(double, max_translation_mm, 30, "eval: a true positive is within this distance");
ABSL_FLAG(double, max_rotation_deg, 10, "eval: ... and within this angle");
ABSL_FLAG(std::string, csv, "", "eval: write one row per ground-truth object to this file");
ABSL_FLAG(bool, keep_maps, false, "eval: keep the eval_<scene> maps");
ABSL_FLAG(int, min_view_frames, 30,
          "eval: a truth is seen when in view (>= 100 visible pixels, within "
          "--max_view_distance) in at least this many streamed frames");
ABSL_FLAG(double, max_view_distance, 3.5, "eval: metres; see --min_view_frames");
ABSL_FLAG(double, min_instance_score, -1,
          "eval: the maps' min_instance_score (instances scoring less are not listed; -1 = "
          "the classifier's; 0 lists all, to sweep the threshold from --summary)");
ABSL_FLAG(double, min_instance_fit, -1, "eval: the maps' min_instance_fit (-1 = the classifier's)");
ABSL_FLAG(double, max_view_conflict, -1,
          "eval: the maps' max_view_conflict (-1 = the classifier's; 1 lists all)");
ABSL_FLAG(bool, single_view, true,
          "eval: also score the single-view baseline (each frame alone: ClassifyImage + PnP)");
ABSL_FLAG(std::string, instances_dir, "",
          "eval: write each scene's instances (map and single view) as JSON files here");
ABSL_FLAG(std::string, summary, "",
          "eval: write the totals and each instance's score and verdict as JSON here");
ABSL_FLAG(bool, train, false,
          "eval: first train every train/ object of DATASET and build the classifier (the "
          "objects train / build flags apply: --detector, --classes_per_object, --trees, ...)");
ABSL_FLAG(std::string, token_file, "",
          "file whose first line is the bearer token sent on every call (default: the "
          "environment variable SKIMAP_TOKEN, if set)");
ABSL_FLAG(std::string, tls_ca, "",
          "TLS: PEM CA certificate(s) that signed skimapd's certificate (TLS is used when any "
          "--tls_* flag is given; without --tls_ca, the system's roots)");
ABSL_FLAG(std::string, tls_cert, "", "TLS: PEM client certificate for mTLS (with --tls_key)");
ABSL_FLAG(std::string, tls_key, "", "TLS: PEM private key of --tls_cert");

namespace {

using skimap::client::MapClient;
namespace v1 = skimap::v1;

// --resolution, or the command's default when it is 0 (not given).
double ResolutionOr(double command_default) {
  const double r = absl::GetFlag(FLAGS_resolution);
  return r != 0 ? r : command_default;
}

int Fail(const absl::Status& s) {
  std::fprintf(stderr, "skimap: %s\n", s.ToString().c_str());
  return 1;
}

// Flags may be spelled with '-' or '_' (--with-journal, --with_journal): abseil knows the
// latter.
std::vector<char*> NormalizeFlagNames(int argc, char** argv, std::vector<std::string>* storage) {
  storage->assign(argv, argv + argc);
  for (std::string& a : *storage) {
    if (a == "--") break;
    if (a.size() < 3 || a.compare(0, 2, "--") != 0) continue;
    const size_t end = std::min(a.find('='), a.size());
    for (size_t i = 2; i < end; ++i) {
      if (a[i] == '-') a[i] = '_';
    }
  }
  std::vector<char*> out;
  for (std::string& a : *storage) out.push_back(a.data());
  return out;
}

}  // namespace

int main(int argc, char** argv) {
#ifdef SKIMAP_WITH_ROS
  // The child that reads a ROS 1 bag before `stream` does (client/cli/bag_frame_source.h).
  if (argc == 3 && std::string(argv[1]) == "__read-ros1-bag") {
    return skimap::client::ReadRos1BagInThisProcess(argv[2]);
  }
#endif
  absl::SetProgramUsageMessage(
      "skimap [--server=host:port] maps ls|create ID|rm ID|info ID\n"
      "       skimap stream DATASET|BAG --map=ID [--fps=N] [--every=N] [--max_frames=N] "
      "[--depth_topic=T --color_topic=T --camera_info_topic=T --fixed_frame=F "
      "--camera_frame=F --sync_tolerance=S --bag_check_seconds=S]\n"
      "       skimap grid --map=ID -o FILE.yaml\n"
      "       skimap heightmap --map=ID -o FILE.png|FILE.tiff\n"
      "       skimap voxels --map=ID -o FILE.ply\n"
      "       skimap export --map=ID -o FILE [--with-journal]\n"
      "       skimap import FILE [--as=ID]\n"
      "       skimap objects ls|info ID|rm ID|train DATASET [--object=ID] "
      "[--detector=SIFT]|add MODEL --object=ID|build|classifier\n"
      "       skimap nodes\n"
      "       skimap health\n"
      "       skimap instances --map=ID [--box=X0,Y0,Z0,X1,Y1,Z1|--sphere=X,Y,Z,R] "
      "[--objects=1,5] [--min_score=S] [--json]\n"
      "       skimap eval DATASET [--scenes=A,B] [--every=N] [--max_frames=N] "
      "[--resolution=0.02] [--max_translation_mm=30] [--max_rotation_deg=10] [--csv=FILE] "
      "[--instances_dir=DIR] [--summary=FILE] [--single_view=false] [--keep_maps] [--train] "
      "[--min_instance_score=S] [--min_instance_fit=F] [--max_view_conflict=V] "
      "[--min_view_frames=30] [--max_view_distance=3.5]");
  std::vector<std::string> arg_storage;
  std::vector<char*> normalized = NormalizeFlagNames(argc, argv, &arg_storage);
  std::vector<char*> positional =
      absl::ParseCommandLine(static_cast<int>(normalized.size()), normalized.data());
  std::vector<std::string> args(positional.begin(), positional.end());
  if (args.size() < 2) {
    std::fprintf(stderr, "%s\n", absl::ProgramUsageMessage().data());
    return 2;
  }
  absl::StatusOr<skimap::client::Connection> connection =
      skimap::client::Connection::FromFiles({.token_file = absl::GetFlag(FLAGS_token_file),
                                             .tls_ca = absl::GetFlag(FLAGS_tls_ca),
                                             .tls_cert = absl::GetFlag(FLAGS_tls_cert),
                                             .tls_key = absl::GetFlag(FLAGS_tls_key)});
  if (!connection.ok()) return Fail(connection.status());
  if (args[1] == "objects") {
    return skimap::client::RunObjectsCommand(absl::GetFlag(FLAGS_server), args, *connection);
  }
  std::unique_ptr<MapClient> client =
      MapClient::Connect(absl::GetFlag(FLAGS_server), {.connection = *connection});
  const std::string& command = args[1];
  const skimap::client::MapCommandFlags map_flags{
      .map = absl::GetFlag(FLAGS_map),
      .out = absl::GetFlag(FLAGS_o),
      .resolution = ResolutionOr(0.05),
      .inflation_radius = absl::GetFlag(FLAGS_inflation_radius),
      .keep_seen_through = absl::GetFlag(FLAGS_keep_seen_through),
      .with_journal = absl::GetFlag(FLAGS_with_journal),
      .as = absl::GetFlag(FLAGS_as)};
  if (command == "maps" || command == "nodes" || command == "health" || command == "import") {
    return skimap::client::RunMapCommand(*client, args, map_flags);
  }
  if (command == "eval") {
    if (args.size() < 3) return Fail(absl::InvalidArgumentError("eval needs a DATASET path"));
    skimap::client::EvalOptions options;
    options.scenes = absl::GetFlag(FLAGS_scenes);
    options.every = absl::GetFlag(FLAGS_every);
    options.max_frames = absl::GetFlag(FLAGS_max_frames);
    // eval's maps default to 2 cm (the documented configuration), not stream's 5 cm.
    options.resolution = ResolutionOr(0.02);
    if (absl::Status s = skimap::client::ApplyMapOptionFlags(&options.map_options); !s.ok()) {
      return Fail(s);
    }
    options.score.max_translation = absl::GetFlag(FLAGS_max_translation_mm) / 1000;
    options.score.max_rotation_deg = absl::GetFlag(FLAGS_max_rotation_deg);
    options.csv = absl::GetFlag(FLAGS_csv);
    options.keep_maps = absl::GetFlag(FLAGS_keep_maps);
    options.single_view = absl::GetFlag(FLAGS_single_view);
    options.instances_dir = absl::GetFlag(FLAGS_instances_dir);
    options.summary = absl::GetFlag(FLAGS_summary);
    options.min_view_frames = absl::GetFlag(FLAGS_min_view_frames);
    options.max_view_distance = absl::GetFlag(FLAGS_max_view_distance);
    if (options.min_view_frames < 0 || !(options.max_view_distance > 0)) {
      return Fail(
          absl::InvalidArgumentError("--min_view_frames must be >= 0 and --max_view_distance > 0"));
    }
    if (const double v = absl::GetFlag(FLAGS_min_instance_score); v != -1) {
      options.min_instance_score = v;
    }
    if (const double v = absl::GetFlag(FLAGS_min_instance_fit); v != -1) {
      options.min_instance_fit = v;
    }
    if (const double v = absl::GetFlag(FLAGS_max_view_conflict); v != -1) {
      options.max_view_conflict = v;
    }
    if (options.every < 1) return Fail(absl::InvalidArgumentError("--every must be at least 1"));
    if (absl::GetFlag(FLAGS_train)) {
      if (absl::Status s =
              skimap::client::TrainAndBuild(absl::GetFlag(FLAGS_server), args[2], *connection);
          !s.ok()) {
        return Fail(s);
      }
    }
    std::unique_ptr<skimap::client::ObjectClient> objects = skimap::client::ObjectClient::Connect(
        absl::GetFlag(FLAGS_server), {.connection = *connection});
    absl::StatusOr<skimap::client::EvalTotals> totals =
        skimap::client::RunEval(*client, *objects, args[2], options);
    return totals.ok() ? 0 : Fail(totals.status());
  }
  const bool needs_map = command == "stream" || command == "grid" || command == "heightmap" ||
                         command == "voxels" || command == "export" || command == "instances";
  if (needs_map && absl::GetFlag(FLAGS_map).empty()) {
    return Fail(absl::InvalidArgumentError(command + " needs --map=ID"));
  }
  if (command != "stream" && command != "instances" && needs_map &&
      absl::GetFlag(FLAGS_o).empty()) {
    return Fail(absl::InvalidArgumentError(command + " needs -o FILE"));
  }
  if (command == "stream") {
    if (args.size() < 3) return Fail(absl::InvalidArgumentError("stream needs a DATASET path"));
    skimap::client::StreamOptions options;
    options.map_id = absl::GetFlag(FLAGS_map);
    options.fps = absl::GetFlag(FLAGS_fps);
    options.resolution = ResolutionOr(0.05);
    if (absl::Status s = skimap::client::ApplyMapOptionFlags(&options.map_options); !s.ok()) {
      return Fail(s);
    }
    options.window = absl::GetFlag(FLAGS_window);
    options.every = absl::GetFlag(FLAGS_every);
    options.max_frames = absl::GetFlag(FLAGS_max_frames);
    if (options.every < 1) return Fail(absl::InvalidArgumentError("--every must be >= 1"));
    if (options.max_frames < 0) {
      return Fail(absl::InvalidArgumentError("--max_frames must be >= 0"));
    }
    options.bag.depth_topic = absl::GetFlag(FLAGS_depth_topic);
    options.bag.color_topic = absl::GetFlag(FLAGS_color_topic);
    options.bag.camera_info_topic = absl::GetFlag(FLAGS_camera_info_topic);
    options.bag.fixed_frame = absl::GetFlag(FLAGS_fixed_frame);
    options.bag.camera_frame = absl::GetFlag(FLAGS_camera_frame);
    options.bag.sync_tolerance = absl::GetFlag(FLAGS_sync_tolerance);
    if (!(options.bag.sync_tolerance >= 0)) {
      return Fail(absl::InvalidArgumentError("--sync_tolerance must be >= 0 seconds"));
    }
    options.bag.check_seconds = absl::GetFlag(FLAGS_bag_check_seconds);
    if (!(options.bag.check_seconds >= 0) || !std::isfinite(options.bag.check_seconds)) {
      return Fail(absl::InvalidArgumentError("--bag_check_seconds must be finite and >= 0"));
    }
    const std::string recognition = absl::GetFlag(FLAGS_recognition);
    if (recognition == "newest" || recognition == "every_frame") {
      options.recognition.emplace();
      options.recognition->set_enabled(true);
      options.recognition->set_policy(recognition == "newest"
                                          ? v1::RecognitionOptions::NEWEST
                                          : v1::RecognitionOptions::EVERY_FRAME);
    } else if (recognition != "off") {
      return Fail(absl::InvalidArgumentError("--recognition: off, newest or every_frame, not \"" +
                                             recognition + "\""));
    }
    const std::string depth_encoding = absl::GetFlag(FLAGS_depth_encoding);
    if (depth_encoding == "auto") {
      options.depth_encoding = skimap::client::kDepthAsStored;
    } else if (depth_encoding == "zstd") {
      options.depth_encoding = skimap::v1::DEPTH_ENCODING_ZSTD;
    } else if (depth_encoding == "rvl") {
      options.depth_encoding = skimap::v1::DEPTH_ENCODING_RVL;
    } else if (depth_encoding == "png16") {
      options.depth_encoding = skimap::v1::DEPTH_ENCODING_PNG16;
    } else if (depth_encoding == "raw") {
      options.depth_encoding = skimap::v1::DEPTH_ENCODING_RAW_U16;
    } else {
      return Fail(
          absl::InvalidArgumentError("--depth_encoding must be auto, zstd, rvl, png16 or raw"));
    }
    absl::Status s = skimap::client::StreamDataset(*client, args[2], options);
    return s.ok() ? 0 : Fail(s);
  }
  if (command == "grid" || command == "heightmap" || command == "voxels" || command == "export") {
    return skimap::client::RunMapCommand(*client, args, map_flags);
  }
  if (command == "instances") {
    skimap::client::InstancesOptions options;
    options.map_id = absl::GetFlag(FLAGS_map);
    options.box = absl::GetFlag(FLAGS_box);
    options.sphere = absl::GetFlag(FLAGS_sphere);
    options.objects = absl::GetFlag(FLAGS_objects);
    options.min_score = absl::GetFlag(FLAGS_min_score);
    options.json = absl::GetFlag(FLAGS_json);
    absl::Status s = skimap::client::RunInstancesCommand(*client, options);
    return s.ok() ? 0 : Fail(s);
  }
  return Fail(absl::InvalidArgumentError("unknown command " + command + " (see --help)"));
}
