// `skimap eval DATASET`: recognition quality and speed on a BOP dataset's test scenes,
// through the server's API, beside a single-view baseline.
//
//   skimap eval DATASET [--scenes=000001,000002] [--every=1] [--max_frames=0]
//               [--resolution=0.02] [--max_translation_mm=30] [--max_rotation_deg=10]
//               [--csv=FILE] [--instances_dir=DIR] [--summary=FILE] [--keep_maps]
//               [--single_view=true]
//               [--train [--detector=SIFT] [--classes_per_object=K] [--trees=T]
//               [--tree_depth=D] [--frame_stride=N]]
//
// Multi-view (the product): each test scene is streamed into a fresh map with recognition
// on (policy EVERY_FRAME: every frame is recognised, so the result does not depend on the
// machine's speed); its instances are scored against the scene's ground truth and the map
// is deleted. Single view (the baseline, client/cli/single_view.h): the same frames, each alone
// through ClassifyImage (the same features and database) and PnP RANSAC, the best view of
// each object kept. Both are scored the same way (client/cli/pose_score.h): precision and
// recall of true positives within --max_translation_mm and --max_rotation_deg of the truth
// or a symmetric equivalent (models_info.json), and BOP's MSSD recall AR_MSSD ("-" when an
// annotated object has no models/obj_XXXXXX.ply).
//
// The server's object database and classifier are used as they are, or first trained from
// DATASET's train split and built with --train (skimap_main runs objects_command.h's
// TrainAndBuild: `skimap objects train DATASET && skimap objects build`).
//
// Prints a Markdown table, one row per scene and the totals, the recall of the truths seen
// (in view in >= --min_view_frames frames within --max_view_distance, view_stats.h), recall
// by viewing distance and by frames in view, then recall per object;
// --csv writes one row per truth (both methods' matches and errors); --instances_dir
// writes each scene's instances as `skimap instances --json` does: <scene>.json (the map's)
// and <scene>.single_view.json (the baseline's), for any BOP-style scorer; --summary writes
// the totals and every instance's score and verdict as JSON (scripts/ablation.py reads it:
// precision-recall curves over the minimum score).
//
// Thread safety: one call at a time.
#ifndef CLIENT_CLI_EVAL_COMMAND_H_
#define CLIENT_CLI_EVAL_COMMAND_H_

#include <optional>
#include <string>

#include "absl/status/status.h"
#include "client/cli/pose_score.h"
#include "client/cli/single_view.h"
#include "client/map_client.h"
#include "client/object_client.h"

namespace skimap::client {

struct EvalOptions {
  std::string scenes;  // comma-separated test scene folder names; empty: all
  int every = 1;       // stream every n-th frame (fewer vantage points)
  int max_frames = 0;  // frames per scene at most; 0: all
  double resolution = 0.02;
  v1::MapOptions map_options;  // more options of the eval maps (the fields set)
  ScoreOptions score;
  std::string csv;            // one row per truth, or empty
  std::string instances_dir;  // per scene instance JSON files, or empty
  std::string summary;        // the totals and each instance's score and verdict, or empty
  bool keep_maps = false;
  bool single_view = true;  // also run the single-view baseline
  // "Seen" truths (view_stats.h): in view in at least min_view_frames streamed frames within
  // max_view_distance metres; their recall is printed beside the plain one.
  int min_view_frames = 30;
  double max_view_distance = 3.5;
  // The maps' visibility thresholds (RecognitionOptions); unset: the server's defaults.
  std::optional<double> min_instance_score, min_instance_fit, max_view_conflict;
  SingleViewOptions single_view_options;
};

// One method's counts, summed over scenes.
struct MethodTotals {
  int instances = 0, true_positives = 0;
  MssdRecall mssd;
};

struct EvalTotals {
  int truths = 0, frames = 0;
  int seen = 0, seen_found = 0;  // truths seen (min_view_frames), and found by the map
  double seconds = 0;            // streaming time, all scenes
  MethodTotals multi_view, single_view;
  bool mssd_available = true;  // every truth's object has a model file
};

// Runs the evaluation; the totals (also printed). `objects` serves the single-view
// baseline (unused when options.single_view is false). Errors: the dataset's (NotFound,
// InvalidArgument naming the file), a scene named in `scenes` that the test split lacks
// (NotFound naming it), an output file that cannot be written, the server's.
absl::StatusOr<EvalTotals> RunEval(MapClient& client, ObjectClient& objects,
                                   const std::string& dataset, const EvalOptions& options);

}  // namespace skimap::client

#endif  // CLIENT_CLI_EVAL_COMMAND_H_
