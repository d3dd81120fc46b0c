// `skimap eval`'s view statistics: frames in view, distances, and the recall tables.
#include "client/cli/view_stats.h"

#include <gtest/gtest.h>

namespace skimap::client {
namespace {

// A frame with one annotation per (distance along the optical axis, visible pixels).
dataset::Frame FrameWith(const std::vector<std::pair<double, int>>& objects) {
  dataset::Frame f;
  for (const auto& [z, px] : objects) {
    dataset::ObjectAnnotation a;
    a.T_m2c.translation() = Eigen::Vector3d(0, 0, z);
    a.px_count_visib = px;
    f.objects.push_back(a);
  }
  return f;
}

TEST(ViewStatsTest, CountsFramesInViewWithinTheDistanceAndEnoughPixels) {
  std::vector<dataset::Frame> frames;
  for (int i = 0; i < 40; ++i) {
    // Truth 0: 2 m, always visible; truth 1: 4 m (beyond 3.5 m); truth 2: 1-1.39 m, but
    // only every second frame shows enough of it.
    frames.push_back(FrameWith({{2.0, 500}, {4.0, 900}, {1.0 + 0.01 * i, i % 2 ? 50 : 150}}));
  }
  const std::vector<ViewStats> s = SceneViewStats(frames, 3, 3.5);
  ASSERT_EQ(s.size(), 3u);
  EXPECT_EQ(s[0].frames_in_view, 40);
  EXPECT_DOUBLE_EQ(s[0].median_distance, 2.0);
  EXPECT_EQ(s[0].median_pixels, 500);
  EXPECT_EQ(s[1].frames_in_view, 0);
  EXPECT_EQ(s[1].median_distance, -1);
  EXPECT_EQ(s[2].frames_in_view, 20);
  EXPECT_NEAR(s[2].min_distance, 1.0, 1e-9);
}

TEST(ViewStatsTest, FramesWithFewerAnnotationsAreSkippedForTheMissingTruths) {
  std::vector<dataset::Frame> frames = {FrameWith({{1.5, 300}}),
                                        FrameWith({{1.5, 300}, {2.5, 300}})};
  const std::vector<ViewStats> s = SceneViewStats(frames, 2, 3.5);
  EXPECT_EQ(s[0].frames_in_view, 2);
  EXPECT_EQ(s[1].frames_in_view, 1);
}

TEST(ViewStatsTest, SeenRecallAndTablesCountTheFoundTruths) {
  ViewRecall r;
  r.Add({.frames_in_view = 100, .median_distance = 2.2}, true);
  r.Add({.frames_in_view = 50, .median_distance = 2.4}, false);
  r.Add({.frames_in_view = 10, .median_distance = 3.1}, true);
  r.Add({}, false);  // never in view
  EXPECT_EQ(r.Seen(30), 2);
  EXPECT_EQ(r.SeenFound(30), 1);
  EXPECT_EQ(r.Seen(0), 4);
  const std::string t = r.Tables();
  EXPECT_NE(t.find("| never in view | 1 | 0 | 0.00 |"), std::string::npos) << t;
  EXPECT_NE(t.find("| 2.0-2.5 | 2 | 1 | 0.50 |"), std::string::npos) << t;
  EXPECT_NE(t.find("| 3.0-3.5 | 1 | 1 | 1.00 |"), std::string::npos) << t;
  EXPECT_NE(t.find("| 30-99 | 1 | 0 | 0.00 |"), std::string::npos) << t;
  EXPECT_NE(t.find("| 100-299 | 1 | 1 | 1.00 |"), std::string::npos) << t;
  EXPECT_NE(t.find("| 10-29 | 1 | 1 | 1.00 |"), std::string::npos) << t;
}

}  // namespace
}  // namespace skimap::client
