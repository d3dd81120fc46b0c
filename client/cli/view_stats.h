// How much of each ground-truth object the camera saw in a scene, for `skimap eval`'s
// recall by viewing distance and by time in view (docs/recognition.md, "Robot view").
//
// A frame has an object "in view" when at least kMinVisiblePixels of it are visible
// (scene_gt_info.json's px_count_visib) and its centre is at most `max_distance` from the
// camera. A truth is "seen" when it was in view in at least `min_frames` of the streamed
// frames: the population whose recall the robot-view figures report.
//
// Thread safety: pure functions and values.
#ifndef CLIENT_CLI_VIEW_STATS_H_
#define CLIENT_CLI_VIEW_STATS_H_

#include <string>
#include <vector>

#include "dataset/types.h"

namespace skimap::client {

inline constexpr int kMinVisiblePixels = 100;

// One truth (one annotation index of the scene's frames) over the streamed frames.
struct ViewStats {
  int frames_in_view = 0;       // frames with the object in view
  double median_distance = -1;  // metres, over those frames; -1 if never in view
  double min_distance = -1;     // metres, over those frames; -1 if never in view
  int median_pixels = 0;        // visible pixels, over those frames
};

// Per annotation index g (frames' objects[g], as in SceneTruths: the first annotated frame
// lists the truths in that order; frames without it or with fewer annotations are
// skipped for g). `max_distance` in metres.
std::vector<ViewStats> SceneViewStats(const std::vector<dataset::Frame>& frames, int truths,
                                      double max_distance);

// Recall of the found truths against their view statistics, as Markdown tables: by median
// in-view distance (0.5 m bins up to 4 m) and by frames in view (0, 1-9, 10-29, 30-99,
// 100-299, 300+), each row "truths | found | recall".
struct ViewRecall {
  std::vector<ViewStats> stats;
  std::vector<bool> found;
  void Add(const ViewStats& s, bool f) {
    stats.push_back(s);
    found.push_back(f);
  }
  // The truths seen (>= min_frames in view) and how many of them were found.
  int Seen(int min_frames) const;
  int SeenFound(int min_frames) const;
  std::string Tables() const;
};

}  // namespace skimap::client

#endif  // CLIENT_CLI_VIEW_STATS_H_
