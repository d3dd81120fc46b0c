// `skimap eval DATASET`: recognition quality and speed on a BOP dataset's test scenes,
// through the server's API. Each test scene is streamed into a fresh map with recognition
// on (policy EVERY_FRAME: every frame is recognised, so the result does not depend on the
// machine's speed), its instances are scored against the scene's ground truth
// (client/pose_score.h: same object, within --max_translation_mm and --max_rotation_deg of
// the truth or of a symmetric equivalent from models_info.json), and the map is deleted.
//
//   skimap eval DATASET [--scenes=000001,000002] [--every=1] [--max_frames=0]
//               [--resolution=0.02] [--max_translation_mm=30] [--max_rotation_deg=10]
//               [--csv=FILE] [--keep_maps]
//
// The server's object database and classifier are used as they are: train them first
// (`skimap objects train DATASET && skimap objects build`). Prints a Markdown table per
// scene (frames, truths, instances, true positives, precision, recall, frames/s of the
// whole pipeline) with the totals, then recall per object; --csv writes one row per truth.
//
// Thread safety: one call at a time.
#ifndef CLIENT_EVAL_COMMAND_H_
#define CLIENT_EVAL_COMMAND_H_

#include <string>

#include "absl/status/status.h"
#include "client/map_client.h"
#include "client/pose_score.h"

namespace skimap::client {

struct EvalOptions {
  std::string scenes;  // comma-separated test scene folder names; empty: all
  int every = 1;       // stream every n-th frame (fewer vantage points)
  int max_frames = 0;  // frames per scene at most; 0: all
  double resolution = 0.02;
  ScoreOptions score;
  std::string csv;  // one row per truth, or empty
  bool keep_maps = false;
};

struct EvalTotals {
  int truths = 0, instances = 0, true_positives = 0, frames = 0;
  double seconds = 0;  // streaming time, all scenes
};

// Runs the evaluation; the totals (also printed). Errors: the dataset's (NotFound,
// InvalidArgument naming the file), a scene named in `scenes` that the test split lacks
// (NotFound naming it), the server's.
absl::StatusOr<EvalTotals> RunEval(MapClient& client, const std::string& dataset,
                                   const EvalOptions& options);

}  // namespace skimap::client

#endif  // CLIENT_EVAL_COMMAND_H_
