// View statistics of the truths. See view_stats.h for the contract.
#include "client/cli/view_stats.h"

#include <algorithm>

#include "absl/strings/str_format.h"

namespace skimap::client {
namespace {

template <typename T>
T Median(std::vector<T> v) {
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

std::string Row(const std::string& label, int n, int found) {
  return absl::StrFormat("| %s | %d | %d | %s |\n", label, n, found,
                         n > 0 ? absl::StrFormat("%.2f", static_cast<double>(found) / n) : "-");
}

}  // namespace

std::vector<ViewStats> SceneViewStats(const std::vector<dataset::Frame>& frames, int truths,
                                      double max_distance) {
  std::vector<ViewStats> out(truths);
  std::vector<std::vector<double>> distances(truths);
  std::vector<std::vector<int>> pixels(truths);
  for (const dataset::Frame& f : frames) {
    for (int g = 0; g < truths && g < static_cast<int>(f.objects.size()); ++g) {
      const dataset::ObjectAnnotation& a = f.objects[g];
      const double distance = a.T_m2c.translation().norm();
      if (a.px_count_visib < kMinVisiblePixels || distance > max_distance) continue;
      distances[g].push_back(distance);
      pixels[g].push_back(a.px_count_visib);
    }
  }
  for (int g = 0; g < truths; ++g) {
    if (distances[g].empty()) continue;
    out[g].frames_in_view = static_cast<int>(distances[g].size());
    out[g].median_distance = Median(distances[g]);
    out[g].min_distance = *std::min_element(distances[g].begin(), distances[g].end());
    out[g].median_pixels = Median(pixels[g]);
  }
  return out;
}

int ViewRecall::Seen(int min_frames) const {
  return static_cast<int>(std::count_if(stats.begin(), stats.end(), [&](const ViewStats& s) {
    return s.frames_in_view >= min_frames;
  }));
}

int ViewRecall::SeenFound(int min_frames) const {
  int n = 0;
  for (size_t i = 0; i < stats.size(); ++i) n += found[i] && stats[i].frames_in_view >= min_frames;
  return n;
}

std::string ViewRecall::Tables() const {
  std::string out =
      "| median distance in view (m) | truths | found | recall |\n|---|---|---|---|\n";
  {
    int n = 0, f = 0;
    for (size_t i = 0; i < stats.size(); ++i) {
      if (stats[i].frames_in_view > 0) continue;
      ++n;
      f += found[i];
    }
    out += Row("never in view", n, f);
  }
  for (double lo = 0; lo < 4; lo += 0.5) {
    int n = 0, f = 0;
    for (size_t i = 0; i < stats.size(); ++i) {
      const double d = stats[i].median_distance;
      if (stats[i].frames_in_view == 0 || d < lo || d >= lo + 0.5) continue;
      ++n;
      f += found[i];
    }
    out += Row(absl::StrFormat("%.1f-%.1f", lo, lo + 0.5), n, f);
  }
  out += "\n| frames in view | truths | found | recall |\n|---|---|---|---|\n";
  const int bounds[] = {0, 1, 10, 30, 100, 300, 1 << 30};
  for (int b = 0; b + 1 < 7; ++b) {
    int n = 0, f = 0;
    for (size_t i = 0; i < stats.size(); ++i) {
      if (stats[i].frames_in_view < bounds[b] || stats[i].frames_in_view >= bounds[b + 1]) continue;
      ++n;
      f += found[i];
    }
    const std::string label = b == 0   ? "0"
                              : b == 5 ? "300+"
                                       : absl::StrFormat("%d-%d", bounds[b], bounds[b + 1] - 1);
    out += Row(label, n, f);
  }
  return out;
}

}  // namespace skimap::client
